// `panelbass render`: a WAV file through a chain file, offline, exactly as the engine runs it; with a
// plant, the transducer simulated for the chained drive and for the bare program, and the two compared.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/json_output.h"
#include "dsp/data_file.h"
#include "dsp/harmonics.h"
#include "dsp/resample.h"
#include "dsp/sample_rate.h"
#include "dsp/sine_fit.h"
#include "dsp/wav_file.h"
#include "engine/chain_file.h"
#include "engine/offline_renderer.h"
#include "models/control/lq_feedforward.h"
#include "models/plant/plant_presets.h"
#include "models/linear/state_space.h"
#include "models/plant/virtual_transducer.h"
#include "models/validation/performance.h"

namespace panelbass::cli {
namespace {

struct RenderOptions {
  std::string chain;
  std::string in;
  std::string out;
  std::string channel = "0";
  std::string plant;
  std::uint64_t seed = 1;
};

// J_c of [2C] (percent) of `y` against `desired`: models::jc_percent on the signals as they are (the
// transducer's simulated output needs no offset correction); null when the desired response is silent.
nlohmann::json j_c_percent(const Eigen::VectorXd& desired, const Eigen::VectorXd& y) {
  if (!(desired.squaredNorm() > 0.0)) return nullptr;
  return models::jc_percent(y, desired);
}

// THD (percent) of a steady sine response, or null.
nlohmann::json steady_thd(const Eigen::VectorXd& y, double fs, double frequency) {
  const std::optional<double> thd = dsp::steady_thd_percent(y, fs, frequency);
  return thd ? nlohmann::json(*thd) : nlohmann::json(nullptr);
}

// The program through the chain's band-pass alone, as configured (a bypassed band-pass passes it as is).
Eigen::VectorXd band_passed(const engine::ChainConfig& config, const Eigen::VectorXd& program) {
  if (config.band_pass.bypass) return program;
  engine::BandPassStage stage(config.band_pass.design);
  stage.prepare({config.fs, config.block});
  Eigen::VectorXd out(program.size());
  for (Eigen::Index k = 0; k < program.size(); ++k) out[k] = stage.process(program[k]);
  return out;
}

/// The desired response y_desired of [2C], and what it was made from.
struct DesiredResponse {
  Eigen::VectorXd y;  ///< at the chain's rate, as long as the program
  std::string name;   ///< what the response is, for the result
};

// The desired response, kept deliberately simple until the control work refines it:
//  - with an LQ feedforward stage, its [7B] desired response y_lin (the controlled linear model) to the
//    band-passed program: the thesis's fig. 7.10 reference, as evaluation/chain_evaluation.cpp uses it;
//  - otherwise the band-passed program through the linearised plant (every nonlinear term off, no
//    sensor noise): what the transducer would give were it linear. Its J_c thus measures the nonlinear
//    distortion and the noise left in the output (and anything a controller changes in the linear
//    response).
DesiredResponse desired_response(const engine::ChainConfig& config, const models::PlantConfig& plant,
                                 const Eigen::VectorXd& program) {
  const Eigen::VectorXd band = band_passed(config, program);
  if (config.feedforward && config.feedforward->model.value("kind", "") == "lq_feedforward") {
    const models::LqFeedforward ff = models::lq_feedforward_from_json(config.feedforward->model);
    return {models::simulate(ff.desired(), band), "LQ feedforward's desired response [7B] to the band-passed program"};
  }
  models::PlantConfig linear = models::linearized(plant);
  linear.sensor.noise_rms_V = 0.0;
  return {models::simulate(linear, band, 1).y, "band-passed program through the linearised plant (no sensor noise)"};
}

// The chain's output and the transducer's, resampled from the chain's rate back to the file's.
Eigen::VectorXd at_file_rate(const Eigen::VectorXd& x, double chain_fs, double file_fs, Eigen::Index samples) {
  Eigen::VectorXd y = dsp::resample(x, chain_fs, file_fs);
  const Eigen::Index kept = std::min(samples, y.size());
  Eigen::VectorXd out = Eigen::VectorXd::Zero(samples);
  out.head(kept) = y.head(kept);
  return out;
}

void run_render(const RenderOptions& o) {
  // Everything that can be refused is checked before any work (and before any progress is printed).
  const engine::ChainConfig config = engine::load_chain_file(o.chain);
  const dsp::Record input = dsp::read_wav(o.in, {o.channel});
  std::optional<models::PlantConfig> plant;
  if (!o.plant.empty()) {
    plant = models::plant_from_name_or_file(o.plant);
    if (!dsp::same_rate(plant->fs, config.fs)) {
      throw std::invalid_argument("--plant " + o.plant + ": the plant runs at " + std::to_string(plant->fs) +
                                  " Hz, the chain (" + o.chain + ") at " + std::to_string(config.fs) + " Hz");
    }
  }
  const std::filesystem::path out_path(o.out);
  if (out_path.extension() != ".wav") throw std::invalid_argument("--out " + o.out + ": must be a .wav file");
  dsp::check_writable_data_file(out_path);
  std::unique_ptr<engine::Chain> chain = engine::make_chain(config);

  const double file_fs = input.fs;
  const Eigen::VectorXd& wav = input.columns.front();
  const bool resampled = !dsp::same_rate(file_fs, config.fs);
  if (resampled) std::cerr << "render: resampling " << file_fs << " Hz -> " << config.fs << " Hz (libsamplerate)\n";
  const Eigen::VectorXd program = resampled ? dsp::resample(wav, file_fs, config.fs) : wav;

  std::cerr << "render: " << program.size() << " samples through " << o.chain << (plant ? " and the plant" : "")
            << "\n";
  engine::RenderOptions options;
  options.block = engine::Samples{config.block};
  options.plant = plant;
  options.noise_seed = o.seed;
  engine::Rendering r = engine::render(*chain, program, options);

  std::vector<std::pair<std::string, Eigen::VectorXd>> columns;
  columns.emplace_back("drive", r.drive);
  nlohmann::json result = {{"chain", o.chain},
                           {"in", o.in},
                           {"channel", o.channel},
                           {"out", o.out},
                           {"fs_in", file_fs},
                           {"fs_chain", config.fs},
                           {"resampled", resampled},
                           {"samples_in", wav.size()},
                           {"samples_chain", program.size()},
                           {"drive_peak", r.drive.size() > 0 ? r.drive.cwiseAbs().maxCoeff() : 0.0}};
  const engine::MetricsSnapshot m = chain->metrics().snapshot();
  result["blocks"] = m.blocks;
  result["faults"] = m.faults;
  result["in_fault"] = m.in_fault;
  result["last_fault"] = engine::fault_name(m.last_fault);
  // What the chain asked of the limiter over the whole program: a sample at or beyond full scale is one
  // the chain could not give (the limiter squeezed it below the rails).
  const bool needs_more_drive = m.over_range_samples > 0;
  result["drive_demand"] = {{"peak_demand", m.peak_demand},
                            {"limited_samples", m.limited_samples},
                            {"over_range_samples", m.over_range_samples},
                            {"needs_more_drive", needs_more_drive}};
  if (needs_more_drive) {
    std::cerr << "render: warning: the program needs more drive than the chain can give: " << m.over_range_samples
              << " of " << m.samples << " samples asked for full scale or more (peak " << m.peak_demand
              << "); the limiter kept the drive inside [-1, 1] and the output distorts there. Lower the program "
                 "or design the controllers for its level (design lq --max-input)\n";
  }

  if (plant) {
    std::cerr << "render: simulating the transducer for the bare program\n";
    // The bare drive is the program itself: no band-pass, no controllers, the same sensor noise.
    const Eigen::VectorXd y_bare = models::simulate(*plant, program, o.seed).y;
    const DesiredResponse desired = desired_response(config, *plant, program);
    columns.emplace_back("y", r.measured);
    columns.emplace_back("y_bare", y_bare);
    columns.emplace_back("y_desired", desired.y);
    result["plant"] = plant->name;
    result["seed"] = o.seed;
    result["desired_response"] = desired.name;
    result["j_c_pct"] = {{"chained", j_c_percent(desired.y, r.measured)}, {"bare", j_c_percent(desired.y, y_bare)}};
    if (const std::optional<double> f = dsp::sine_frequency(program, config.fs)) {
      result["sine"] = {{"frequency_hz", *f},
                        {"thd_pct", {{"chained", steady_thd(r.measured, config.fs, *f)},
                                     {"bare", steady_thd(y_bare, config.fs, *f)}}}};
    } else {
      result["sine"] = nullptr;
    }
  }

  dsp::Record output;
  output.fs = file_fs;
  nlohmann::json names = nlohmann::json::array();
  for (auto& [name, values] : columns) {
    output.add(name, resampled ? at_file_rate(values, config.fs, file_fs, wav.size()) : std::move(values));
    names.push_back(name);
  }
  dsp::write_wav(out_path, output, dsp::WavFormat::float32);
  result["columns"] = names;
  std::cerr << "render: wrote " << o.out << "\n";
  print_result(result);
}

}  // namespace

void register_render(CLI::App& app) {
  auto o = std::make_shared<RenderOptions>();
  CLI::App* cmd = app.add_subcommand(
      "render", "Render a WAV file through a chain file offline (resampled to the chain's rate and back)");
  cmd->add_option("--chain", o->chain, "Chain file (panelbass.chain/1)")->required();
  cmd->add_option("--in", o->in, "Input WAV file (the program), at any rate")->required();
  cmd->add_option("--out", o->out, "Output WAV file (32-bit float) at the input's rate: columns drive and, "
                                   "with --plant, y, y_bare, y_desired")
      ->required();
  cmd->add_option("--channel", o->channel, "Input channel: a zero-based index or a panelbass channel name")
      ->capture_default_str();
  cmd->add_option("--plant", o->plant,
                  "Also simulate the transducer: a preset (panel-exciter, linear) or a plant JSON file");
  cmd->add_option("--seed", o->seed, "Seed of the plant's sensor noise")->capture_default_str();
  cmd->footer(
      "Example:\n  panelbass render --chain chain.json --in music-48k.wav --out rendered.wav --plant panel-exciter\n"
      "Prints one JSON object; with --plant, J_c of [2C] (percent) for the chained and the bare drive, and\n"
      "their THD at the program's frequency when the program is a sine. drive_demand says what the chain asked\n"
      "of its limiter (peak_demand, over_range_samples); needs_more_drive (and a warning on stderr): some\n"
      "sample asked for full scale or more, more drive than the chain can give.");
  cmd->callback([o] { run_render(*o); });
}

}  // namespace panelbass::cli

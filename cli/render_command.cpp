// `panelbass render`: a WAV file through a chain file, offline, exactly as the engine runs it; with a
// plant, the transducer simulated for the chained drive and for the bare program, and the two compared.
#include <Eigen/Core>
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <iostream>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <unsupported/Eigen/FFT>
#include <vector>

#include "cli/commands.h"
#include "cli/json_output.h"
#include "dsp/data_file.h"
#include "dsp/harmonics.h"
#include "dsp/resample.h"
#include "dsp/wav_file.h"
#include "engine/chain_file.h"
#include "engine/offline_renderer.h"
#include "models/control/lq_feedforward.h"
#include "models/plant/plant_presets.h"
#include "models/linear/state_space.h"
#include "models/plant/virtual_transducer.h"

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

constexpr double kPi = std::numbers::pi;

// The least-squares fit of a·cos(2πfk/fs) + b·sin(2πfk/fs) + c to `x`: its coefficients and the
// energy it leaves unexplained.
struct SineFit {
  Eigen::Vector3d coefficients;
  double residual = 0.0;
};

SineFit fit_sine(const Eigen::VectorXd& x, double fs, double f) {
  // Normal equations BᵀB·θ = Bᵀx with B = [cos, sin, 1], accumulated without forming B.
  Eigen::Matrix3d btb = Eigen::Matrix3d::Zero();
  Eigen::Vector3d btx = Eigen::Vector3d::Zero();
  const double w = 2.0 * kPi * f / fs;
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    const Eigen::Vector3d b(std::cos(w * static_cast<double>(k)), std::sin(w * static_cast<double>(k)), 1.0);
    btb.noalias() += b * b.transpose();
    btx += b * x[k];
  }
  SineFit fit;
  fit.coefficients = btb.ldlt().solve(btx);
  // ‖x − Bθ‖² = xᵀx − θᵀBᵀx at the least-squares θ
  fit.residual = std::max(0.0, x.squaredNorm() - fit.coefficients.dot(btx));
  return fit;
}

// The frequency of `x` if it is a sine (with an offset): the strongest FFT bin, refined by a golden-section
// search for the least-squares sinusoid over the neighbouring bins (the maximum-likelihood frequency), and
// accepted when that sinusoid leaves less than 0.1 % of the signal's energy about its mean.
std::optional<double> sine_frequency(const Eigen::VectorXd& x, double fs) {
  const Eigen::Index n = x.size();
  if (n < 64) return std::nullopt;
  const Eigen::VectorXd centred = x.array() - x.mean();
  const double energy = centred.squaredNorm();
  if (!(energy > 0.0)) return std::nullopt;
  Eigen::Index size = 1;
  while (size < 2 * n) size *= 2;
  Eigen::VectorXd padded = Eigen::VectorXd::Zero(size);
  padded.head(n) = centred;
  Eigen::FFT<double> fft;
  Eigen::VectorXcd spectrum;
  fft.fwd(spectrum, padded);
  Eigen::Index peak = 1;
  for (Eigen::Index k = 1; k < size / 2; ++k) {
    if (std::abs(spectrum[k]) > std::abs(spectrum[peak])) peak = k;
  }
  const double bin = fs / static_cast<double>(size);
  double lo = std::max(bin * (static_cast<double>(peak) - 1.0), 1e-9);
  double hi = std::min(bin * (static_cast<double>(peak) + 1.0), fs / 2.0 - 1e-9);
  const double golden = (std::sqrt(5.0) - 1.0) / 2.0;
  double a = hi - golden * (hi - lo), b = lo + golden * (hi - lo);
  double ra = fit_sine(x, fs, a).residual, rb = fit_sine(x, fs, b).residual;
  while (hi - lo > 1e-10 * fs) {
    if (ra > rb) {
      lo = a;
      a = b;
      ra = rb;
      b = lo + golden * (hi - lo);
      rb = fit_sine(x, fs, b).residual;
    } else {
      hi = b;
      b = a;
      rb = ra;
      a = hi - golden * (hi - lo);
      ra = fit_sine(x, fs, a).residual;
    }
  }
  const double f = (lo + hi) / 2.0;
  if (fit_sine(x, fs, f).residual > 1e-3 * energy) return std::nullopt;
  return f;
}

// THD (percent) of the steady state of `y` at `frequency`: its last three quarters, cut to the whole
// number of periods whose length in samples is closest to an integer (the single-bin DFT of
// dsp::harmonic_levels is exact for whole periods). Null when fewer than 4 periods are left.
nlohmann::json steady_thd(const Eigen::VectorXd& y, double fs, double frequency) {
  const Eigen::Index start = y.size() / 4;
  const double period = fs / frequency;
  const auto most = static_cast<long>(std::floor(static_cast<double>(y.size() - start) / period));
  if (most < 4) return nullptr;
  long best = most;
  double best_miss = 1.0;
  for (long m = most; m >= std::max(4L, most / 2); --m) {
    const double len = static_cast<double>(m) * period;
    const double miss = std::abs(len - std::round(len));
    if (miss < best_miss - 1e-12) {
      best = m;
      best_miss = miss;
    }
  }
  const auto len = std::min<Eigen::Index>(static_cast<Eigen::Index>(std::llround(static_cast<double>(best) * period)),
                                          y.size() - start);
  const Eigen::VectorXd steady = y.segment(y.size() - len, len);
  const double thd = dsp::harmonic_levels(steady, fs, frequency, 5).thd_percent();
  return std::isfinite(thd) ? nlohmann::json(thd) : nlohmann::json(nullptr);
}

// [2C] J_c = Σ(y_desired − y)² / Σ y_desired², in percent, each signal's mean removed first (an
// accelerometer is AC-coupled; a sensor offset is not distortion); null when y_desired is constant.
nlohmann::json j_c_percent(const Eigen::VectorXd& desired, const Eigen::VectorXd& y) {
  const Eigen::VectorXd d = desired.array() - desired.mean();
  const double norm = d.squaredNorm();
  if (!(norm > 0.0)) return nullptr;
  return 100.0 * (d - (y.array() - y.mean()).matrix()).squaredNorm() / norm;
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
//    band-passed program: the thesis's fig. 7.10 reference, as engine/chain_evaluation.cpp uses it;
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
    if (!(std::abs(plant->fs - config.fs) <= 1e-9 * config.fs)) {
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
  const bool resampled = !(std::abs(file_fs - config.fs) <= 1e-9 * config.fs);
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
    if (const std::optional<double> f = sine_frequency(program, config.fs)) {
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
      "their THD at the program's frequency when the program is a sine.");
  cmd->callback([o] { run_render(*o); });
}

}  // namespace panelbass::cli

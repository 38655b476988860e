#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "cli/commands.h"
#include "cli/json_output.h"
#include "cli/progress_bar.h"
#include "dsp/data_file.h"
#include "cli/band_pass_option.h"
#include "dsp/excitation.h"
#include "dsp/sample_rate.h"
#include "models/control/feedback_design.h"
#include "models/io/json_file.h"
#include "models/control/neural_feedback.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::cli {
namespace {

struct SimulateOptions {
  std::string plant = "panel-exciter";
  std::string signal = "noise";
  double amplitude = 1.0;
  std::size_t samples = 0;
  std::uint64_t seed = 1;
  std::uint64_t noise_seed = 0;
  bool noise_seed_given = false;
  double freq = 0.0;
  double f_min = 10.0;
  double f_max = 1200.0;
  std::string lines = "all";
  std::size_t period = 0;
  std::vector<double> freqs;
  std::size_t settle = 600;
  std::size_t measure = 3000;
  std::string ff;
  std::string fb;
  std::string bandpass = "20,1200";
  double sine_peak = 1.0;
  double program_share = models::FeedbackDesignOptions{}.program_share;
  std::string out;
};

/// --signal control's record: the drive the feedforward chain produces for the controller design's program
/// (noise + stepped sines), with its steps and linear response for the harmonic weights. With --fb, the drive
/// is the neural feedback controller's behind the feedforward, run in model mode (fig. 7.10 with its own plant
/// model, as `chain --source model` runs it): a closed-loop record, to refine the plant model where the
/// controller drives it.
models::ControlRecord make_control_record(const SimulateOptions& o, double fs) {
  if (o.ff.empty()) throw std::invalid_argument("--signal control needs --ff FF.json");
  const models::LqFeedforward ff = models::lq_feedforward_from_json(models::read_json_file(o.ff));
  if (!dsp::same_rate(ff.fs, fs)) throw std::invalid_argument("--ff " + o.ff + ": designed at another rate than the plant's");
  models::FeedbackDesignOptions design;
  design.samples = static_cast<Eigen::Index>(o.samples);
  design.sine_peak = o.sine_peak;
  design.program_share = o.program_share;
  models::ControlRecord record = models::control_record(ff, band_pass_sections(o.bandpass, 2, fs), design, o.seed);
  if (!o.fb.empty()) {
    const models::NeuralFeedback fb = models::neural_feedback_from_json(models::read_json_file(o.fb));
    if (!dsp::same_rate(fb.fs, fs)) throw std::invalid_argument("--fb " + o.fb + ": designed at another rate than the plant's");
    record.u = models::simulate_closed_loop(fb, record.u).v;
  }
  return record;
}

/// The excitation of every signal but control.
Eigen::VectorXd make_excitation(const SimulateOptions& o, double fs) {
  if (o.signal == "stepped") {
    // The same layout `panelbass harmonics --data` expects: settle, then measure, per frequency.
    if (o.freqs.empty()) throw std::invalid_argument("--signal stepped needs --freqs F1,F2,…");
    dsp::SteppedSineSpec spec;
    spec.frequencies = o.freqs;
    spec.fs = fs;
    spec.amplitude = o.amplitude;
    spec.settle = o.settle;
    spec.measure = o.measure;
    return dsp::stepped_sine(spec).signal;
  }
  if (o.signal == "noise") return dsp::uniform_noise(o.samples, o.amplitude, o.seed);
  if (o.signal == "gauss") return dsp::gaussian_noise(o.samples, o.amplitude, o.seed);
  if (o.signal == "sweep") return dsp::log_sweep(o.samples, fs, o.f_min, o.f_max, o.amplitude);
  if (o.signal == "sine") {
    if (!(o.freq > 0.0)) throw std::invalid_argument("--signal sine needs --freq HZ");
    return dsp::sine(o.samples, fs, o.freq, o.amplitude);
  }
  // multisine: periods of `period` samples (default: one period over the whole record)
  const std::size_t period = o.period == 0 ? o.samples : o.period;
  if (o.samples % period != 0) {
    throw std::invalid_argument("--samples " + std::to_string(o.samples) + " is not a whole number of --period " +
                                std::to_string(period));
  }
  dsp::MultisineSpec spec;
  spec.period = period;
  spec.periods = o.samples / period;
  spec.fs = fs;
  spec.f_min = o.f_min;
  spec.f_max = o.f_max;
  spec.lines = o.lines == "odd" ? dsp::MultisineLines::odd
               : o.lines == "random-odd" ? dsp::MultisineLines::random_odd
                                          : dsp::MultisineLines::all;
  spec.amplitude = o.amplitude;
  spec.seed = o.seed;
  return dsp::multisine(spec).signal;
}

double rms(const Eigen::VectorXd& x) { return std::sqrt(x.squaredNorm() / static_cast<double>(x.size())); }

void run_simulate(const SimulateOptions& o) {
  if (o.samples == 0 && o.signal != "stepped") throw CLI::RequiredError("--samples");
  if (!o.fb.empty() && o.signal != "control") throw std::invalid_argument("--fb needs --signal control");
  const models::PlantConfig plant = models::plant_from_name_or_file(o.plant);
  dsp::check_writable_data_file(o.out);
  const bool control = o.signal == "control";
  const models::ControlRecord control_record = control ? make_control_record(o, plant.fs) : models::ControlRecord{};
  const Eigen::VectorXd u = control ? control_record.u : make_excitation(o, plant.fs);
  const auto samples = static_cast<std::size_t>(u.size());
  ProgressBar bar("simulate");
  const std::uint64_t noise_seed = o.noise_seed_given ? o.noise_seed : o.seed + 1;
  const models::PlantRecord r = models::simulate(plant, u, noise_seed, [&bar](double f) { bar.update(f); });

  dsp::Record record;
  record.fs = plant.fs;
  record.add("u", u);
  record.add("y", r.y);
  record.add("i", r.i);
  record.add("x", r.x);
  // for identify narx --weight-col w: every step's harmonics count alike (models::harmonic_weights)
  if (control) record.add("w", models::harmonic_weights(control_record, r.y, plant.fs));
  dsp::write_data_file(o.out, record);

  print_result({{"samples", samples},
                {"fs", plant.fs},
                {"plant", plant.name},
                {"signal", o.signal},
                {"seed", o.seed},
                {"noise_seed", noise_seed},
                {"out", o.out},
                {"rms", {{"u", rms(u)}, {"y", rms(r.y)}, {"i", rms(r.i)}, {"x", rms(r.x)}}}});
}

}  // namespace

void register_simulate(CLI::App& app) {
  auto o = std::make_shared<SimulateOptions>();
  CLI::App* cmd = app.add_subcommand("simulate", "Drive the virtual transducer with an excitation and record it");
  cmd->add_option("--plant", o->plant, "Preset (panel-exciter, linear) or plant JSON file")->capture_default_str();
  cmd->add_option("--signal", o->signal, "Excitation")
      ->check(CLI::IsMember({"noise", "gauss", "multisine", "sweep", "sine", "stepped", "control"}))
      ->capture_default_str();
  cmd->add_option("--amplitude", o->amplitude, "Peak drive, within (0, 1]")
      ->check(CLI::Range(1e-12, 1.0))
      ->capture_default_str();
  cmd->add_option("--samples", o->samples, "Number of samples (required but for --signal stepped)")
      ->check(CLI::Range(1, 100000000));
  cmd->add_option("--seed", o->seed, "Seed of the excitation")->capture_default_str();
  cmd->add_option("--ff", o->ff, "--signal control: the LQ feedforward controller whose output drives the plant");
  cmd->add_option("--fb", o->fb,
                  "--signal control: a neural feedback controller (design nn) behind the feedforward, run with its own plant "
                  "model (model mode): the drive is the loop's, for refining the plant model where the controller drives it");
  add_bandpass_option(cmd, o->bandpass, "--signal control: band-pass corners LO,HI in front of it, Hz");
  cmd->add_option("--sine-peak", o->sine_peak, "--signal control: steady feedforward peak of the stepped sines (program peak where the chain's gain is below 1)")
      ->check(CLI::Range(1e-6, 1.0))
      ->capture_default_str();
  cmd->add_option("--program-share", o->program_share,
                  "--signal control: share of the stepped sines at a program level (the rest at the drive level)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--noise-seed", o->noise_seed, "Seed of the sensor noise (default: seed + 1)")
      ->each([o](const std::string&) { o->noise_seed_given = true; });
  cmd->add_option("--freq", o->freq, "Frequency of --signal sine, Hz")->check(CLI::PositiveNumber);
  cmd->add_option("--f-min", o->f_min, "Lowest frequency of a sweep or multisine, Hz")->capture_default_str();
  cmd->add_option("--f-max", o->f_max, "Highest frequency of a sweep or multisine, Hz")->capture_default_str();
  cmd->add_option("--lines", o->lines, "Multisine lines")
      ->check(CLI::IsMember({"all", "odd", "random-odd"}))
      ->capture_default_str();
  cmd->add_option("--period", o->period, "Multisine period in samples (default: the whole record)");
  cmd->add_option("--freqs", o->freqs, "Fundamentals of --signal stepped, Hz")->delimiter(',')->check(CLI::PositiveNumber);
  cmd->add_option("--settle", o->settle, "Stepped sine: samples before each measured part")->capture_default_str();
  cmd->add_option("--measure", o->measure, "Stepped sine: measured samples per frequency")->capture_default_str();
  cmd->add_option("--out", o->out, "Output file, .csv or .wav (columns u,y,i,x; --signal control adds w, the harmonic weights for identify narx --weight-col w)")->required();
  cmd->footer(
      "Example:\n  panelbass simulate --plant panel-exciter --signal noise --amplitude 1 --samples 12000 "
      "--seed 1 --out run.csv\n"
      "  panelbass simulate --signal control --ff ff.json --fb fb.json --samples 22500 --sine-peak 0.6 --seed 7 --out loop.csv");
  cmd->callback([o] { run_simulate(*o); });
}

}  // namespace panelbass::cli

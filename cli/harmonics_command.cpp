#include <algorithm>
#include <functional>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/json_output.h"
#include "cli/usecase_door.h"
#include "models/analysis/distortion_comparison.h"
#include "models/io/json_fields.h"
#include "models/kinds/model_file.h"
#include "models/io/json_file.h"
#include "models/plant/plant_presets.h"
#include "usecases/harmonics.h"

namespace panelbass::cli {
namespace {

// The options of `harmonics`; the defaults are the request's (usecases::HarmonicsRequest).
struct HarmonicsOptions {
  std::string plant = "panel-exciter";
  std::string model;
  std::vector<double> frequencies = usecases::HarmonicsRequest{}.frequencies;
  std::vector<double> amplitudes = usecases::HarmonicsRequest{}.amplitudes;
  bool noise = usecases::HarmonicsRequest{}.noise;
  std::string data;
  DataOptions columns;
  std::size_t settle = static_cast<std::size_t>(usecases::HarmonicsRequest{}.settle);
  std::size_t measure = static_cast<std::size_t>(usecases::HarmonicsRequest{}.measure);
};

// The stepped sine's drive in, the recording's response out: a recording made with the stepped sine of these
// options (`panelbass simulate --signal stepped`, or played through real hardware); its input column must be that
// signal.
std::function<Eigen::VectorXd(const Eigen::VectorXd&)> recording_system(const HarmonicsOptions& o, const dsp::Record& rec) {
  return [&o, &rec](const Eigen::VectorXd& drive) -> Eigen::VectorXd {
    const Eigen::VectorXd& u = rec.columns[0];
    if (drive.size() != u.size()) {
      throw std::invalid_argument(o.data + ": " + std::to_string(u.size()) + " samples, but the stepped sine for these "
                                  "--freqs/--settle/--measure has " + std::to_string(drive.size()));
    }
    Eigen::Index worst = 0;
    const double mismatch = (drive - u).cwiseAbs().maxCoeff(&worst);
    if (mismatch > 1e-3 * o.amplitudes[0]) {
      throw std::invalid_argument(o.data + ": column \"" + o.columns.input_col + "\" is not the stepped sine for these "
                                  "--freqs/--amplitudes/--settle/--measure (sample " + std::to_string(worst) +
                                  " differs by " + std::to_string(mismatch) + ")");
    }
    return rec.columns[1];
  };
}

void run_harmonics(const HarmonicsOptions& o) {
  usecases::HarmonicsRequest q;
  q.frequencies = o.frequencies;
  q.amplitudes = o.amplitudes;
  q.noise = o.noise;
  q.settle = static_cast<long>(o.settle);
  q.measure = static_cast<long>(o.measure);
  if (!o.model.empty()) {
    q.model = models::read_json_file(o.model);
    q.model_name = o.model;
  }
  dsp::Record rec;
  if (!o.data.empty()) {
    if (o.amplitudes.size() != 1) throw std::invalid_argument("--data takes exactly one --amplitudes value");
    rec = o.columns.read(o.data);
    q.system = recording_system(o, rec);
    q.fs = rec.fs;
    q.source_name = o.data;
  } else {
    q.plant = models::plant_from_name_or_file(o.plant);
    q.source_name = q.plant->name;
  }
  usecases::SilentProgress quiet;
  print_result(run_use_case([&] { return usecases::harmonics(q, quiet); },
                            {{{"frequencies", "--freqs"}}, {{"model", o.model}}}));
}

}  // namespace

void register_harmonics(CLI::App& app) {
  auto o = std::make_shared<HarmonicsOptions>();
  CLI::App* cmd = app.add_subcommand(
      "harmonics",
      "Harmonic distortion by stepped sine: a plant, and a model of it side by side (thesis fig. 6.7), with each\n"
      "harmonic's level and phase against the fundamental and, beside a model, how much of the measured distortion\n"
      "a canceller designed on that model would remove (cancellable_db; the levels alone give an upper bound)");
  cmd->add_option("--plant", o->plant, "Preset (panel-exciter, linear) or plant JSON file")->capture_default_str();
  cmd->add_option("--model", o->model, "Model file to compare with the plant");
  cmd->add_option("--freqs", o->frequencies, "Fundamentals, Hz")->delimiter(',')->check(CLI::PositiveNumber);
  cmd->add_option("--amplitudes", o->amplitudes, "Drive amplitudes within (0, 1]")->delimiter(',')->check(CLI::Range(1e-6, 1.0));
  cmd->add_flag("--noise", o->noise, "Keep the plant's sensor noise (default: the physics alone)");
  cmd->add_option("--data", o->data, "A recording made with the stepped sine (instead of --plant)");
  o->columns.add_to(cmd);
  cmd->add_option("--settle", o->settle, "Samples before each measured part")->capture_default_str();
  cmd->add_option("--measure", o->measure, "Measured samples per frequency")->capture_default_str();
  cmd->footer(
      "Examples:\n  panelbass harmonics --plant panel-exciter --model nn.json --freqs 40,80,160,320 --amplitudes 0.5,0.8\n"
      "  panelbass simulate --signal stepped --freqs 40,80,160 --amplitude 0.8 --out rec.csv\n"
      "  panelbass harmonics --data rec.csv --fs 3000 --freqs 40,80,160 --amplitudes 0.8 --model nn.json");
  cmd->callback([o] { run_harmonics(*o); });
}

}  // namespace panelbass::cli

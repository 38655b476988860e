#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/json_output.h"
#include "models/analysis/distortion_comparison.h"
#include "models/io/json_fields.h"
#include "models/kinds/model_file.h"
#include "models/plant/plant_presets.h"

namespace panelbass::cli {
namespace {

struct HarmonicsOptions {
  std::string plant = "panel-exciter";
  std::string model;
  std::vector<double> frequencies{40, 60, 80, 100, 150, 200, 300, 400, 600};
  std::vector<double> amplitudes{0.8};
  bool noise = false;
  std::string data;
  DataOptions columns;
  std::size_t settle = 600;
  std::size_t measure = 3000;
};

nlohmann::json rows_json(const std::vector<models::DistortionRow>& rows) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& r : rows) {
    nlohmann::json levels = nlohmann::json::object(), phases = nlohmann::json::object();
    for (std::size_t h = 0; h < r.harmonic_db.size(); ++h) {
      const std::string name = "H" + std::to_string(h + 2);
      levels[name + "_db"] = models::number_or_null(r.harmonic_db[h]);
      // against a cosine fundamental of phase zero (dsp::HarmonicLevels::relative), degrees
      const double phase = h < r.harmonic_relative.size() ? std::arg(r.harmonic_relative[h]) : std::nan("");
      phases[name + "_deg"] = models::number_or_null(phase * 180.0 / std::numbers::pi);
    }
    out.push_back({{"frequency_hz", r.frequency},
                   {"amplitude", r.amplitude},
                   {"fundamental", r.fundamental},
                   {"harmonics", levels},
                   {"phases", phases},
                   {"thd_pct", models::number_or_null(r.thd_percent)}});
  }
  return out;
}

// Per row, how much of the measured distortion a canceller designed on the model would remove
// (models::cancellable_db, and the levels-only bound); the smallest over the rows summarises it.
void add_cancellation(nlohmann::json& result, const std::vector<models::DistortionRow>& measured,
                      const std::vector<models::DistortionRow>& model) {
  nlohmann::json rows = nlohmann::json::array();
  double smallest = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < measured.size() && k < model.size(); ++k) {
    const double db = models::cancellable_db(measured[k], model[k]);
    const double levels_db = models::cancellable_magnitude_db(measured[k], model[k]);
    smallest = std::min(smallest, db);
    rows.push_back({{"frequency_hz", measured[k].frequency},
                    {"amplitude", measured[k].amplitude},
                    {"cancellable_db", models::number_or_null(db)},
                    {"cancellable_magnitude_db", models::number_or_null(levels_db)}});
  }
  result["cancellable"] = rows;
  result["smallest_cancellable_db"] = models::number_or_null(smallest);
}

// A recording made with the stepped sine of `spec` (`panelbass simulate --signal stepped`, or played
// through real hardware): its input column must be that signal; its output column is what is analysed.
std::vector<models::DistortionRow> recording_distortion(const HarmonicsOptions& o, const models::DistortionSpec& spec) {
  if (spec.amplitudes.size() != 1) throw std::invalid_argument("--data takes exactly one --amplitudes value");
  const dsp::Record rec = o.columns.read(o.data);
  const Eigen::VectorXd& u = rec.columns[0];
  const Eigen::VectorXd& y = rec.columns[1];
  const auto system = [&](const Eigen::VectorXd& drive) -> Eigen::VectorXd {
    if (drive.size() != u.size()) {
      throw std::invalid_argument(o.data + ": " + std::to_string(u.size()) + " samples, but the stepped sine for these "
                                  "--freqs/--settle/--measure has " + std::to_string(drive.size()));
    }
    Eigen::Index worst = 0;
    const double mismatch = (drive - u).cwiseAbs().maxCoeff(&worst);
    if (mismatch > 1e-3 * spec.amplitudes[0]) {
      throw std::invalid_argument(o.data + ": column \"" + o.columns.input_col + "\" is not the stepped sine for these "
                                  "--freqs/--amplitudes/--settle/--measure (sample " + std::to_string(worst) +
                                  " differs by " + std::to_string(mismatch) + ")");
    }
    return y;
  };
  return models::measure_distortion(system, rec.fs, spec);
}

void run_harmonics(const HarmonicsOptions& o) {
  models::DistortionSpec spec;
  spec.frequencies = o.frequencies;
  spec.amplitudes = o.amplitudes;
  spec.settle = o.settle;
  spec.measure = o.measure;
  spec.sensor_noise = o.noise ? models::SensorNoise::keep : models::SensorNoise::off;
  if (!o.data.empty()) {
    const std::vector<models::DistortionRow> recorded = recording_distortion(o, spec);
    nlohmann::json result = {{"data", o.data}, {"recording_rows", rows_json(recorded)}};
    if (!o.model.empty()) {
      const std::vector<models::DistortionRow> modelled = models::model_distortion(models::load_model(o.model), spec);
      result["model_rows"] = rows_json(modelled);
      add_cancellation(result, recorded, modelled);
    }
    print_result(result);
    return;
  }
  const models::PlantConfig plant = models::plant_from_name_or_file(o.plant);
  nlohmann::json result = {{"plant", plant.name}, {"fs", plant.fs}};
  if (o.model.empty()) {
    result["plant_rows"] = rows_json(models::plant_distortion(plant, spec));
  } else {
    // The thesis's fig. 6.7: the harmonics the process makes against those its model makes.
    const models::AnyModel model = models::load_model(o.model);
    const models::DistortionComparison c = models::compare_distortion(plant, model, spec);
    result["model"] = o.model;
    result["kind"] = model.kind();
    result["plant_rows"] = rows_json(c.plant);
    result["model_rows"] = rows_json(c.model);
    add_cancellation(result, c.plant, c.model);
  }
  print_result(result);
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

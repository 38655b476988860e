#include "usecases/harmonics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "models/analysis/distortion_comparison.h"
#include "models/io/json_fields.h"
#include "models/io/number_text.h"
#include "models/kinds/model_file.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

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

}  // namespace

void check(const HarmonicsRequest& q) {
  if (!q.plant && !q.system) throw RequestError("plant", "a plant to simulate or a system to play is needed");
  if (q.frequencies.empty()) throw RequestError("frequencies", "at least one fundamental is needed");
  for (const double f : q.frequencies) {
    if (!(std::isfinite(f) && f > 0.0)) throw RequestError("frequencies", "each must be > 0 Hz, got " + models::number_text(f));
  }
  if (q.amplitudes.empty()) throw RequestError("amplitudes", "at least one amplitude is needed");
  for (const double a : q.amplitudes) {
    if (!(a > 0.0 && a <= 1.0)) throw RequestError("amplitudes", "each must be within (0, 1], got " + models::number_text(a));
  }
  if (q.settle < 0 || q.settle > 10'000'000) throw RequestError("settle", "must be within 0..10000000, got " + std::to_string(q.settle));
  if (q.measure < 16 || q.measure > 10'000'000) {
    throw RequestError("measure", "must be within 16..10000000, got " + std::to_string(q.measure));
  }
}

nlohmann::json to_json(const HarmonicsRequest& q) {
  return {{"plant", q.source_name}, {"model", q.model.is_null() ? nlohmann::json(nullptr) : nlohmann::json(q.model_name)},
          {"frequencies", q.frequencies}, {"amplitudes", q.amplitudes}, {"noise", q.noise},
          {"settle", q.settle},           {"measure", q.measure}};
}

nlohmann::json harmonics(const HarmonicsRequest& q, Progress& progress) {
  check(q);
  models::DistortionSpec spec;
  spec.frequencies = q.frequencies;
  spec.amplitudes = q.amplitudes;
  spec.settle = static_cast<std::size_t>(q.settle);
  spec.measure = static_cast<std::size_t>(q.measure);
  spec.sensor_noise = q.noise ? models::SensorNoise::keep : models::SensorNoise::off;
  std::optional<models::AnyModel> model;
  if (!q.model.is_null()) {
    try {
      model = models::model_from_json(q.model);
    } catch (const std::exception& e) {
      throw RequestError("model", e.what());
    }
  }
  progress.report(0.0, "stepped sines through " + q.source_name);
  nlohmann::json result;
  std::vector<models::DistortionRow> measured;
  if (q.plant) {
    result = {{"plant", q.plant->name}, {"fs", q.plant->fs}};
    if (model) {
      // The thesis's fig. 6.7: the harmonics the process makes against those its model makes.
      const models::DistortionComparison c = models::compare_distortion(*q.plant, *model, spec);
      result["plant_rows"] = rows_json(c.plant);
      result["model_rows"] = rows_json(c.model);
      add_cancellation(result, c.plant, c.model);
    } else {
      result["plant_rows"] = rows_json(models::plant_distortion(*q.plant, spec));
    }
  } else {
    measured = models::measure_distortion(q.system, q.fs, spec);
    result = {{"data", q.source_name}, {"fs", q.fs}, {"recording_rows", rows_json(measured)}};
    if (model) {
      const std::vector<models::DistortionRow> modelled = models::model_distortion(*model, spec);
      result["model_rows"] = rows_json(modelled);
      add_cancellation(result, measured, modelled);
    }
  }
  if (model) {
    result["model"] = q.model_name;
    result["kind"] = model->kind();
  }
  progress.report(1.0, "done");
  return result;
}

}  // namespace panelbass::usecases

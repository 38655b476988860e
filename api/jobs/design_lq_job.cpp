#include "api/jobs/design_lq_job.h"

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/stored_models.h"
#include "dsp/butterworth.h"
#include "dsp/decibels.h"
#include "dsp/frequency_grid.h"
#include "models/control/lq_feedforward.h"
#include "models/control/lq_weight_search.h"
#include "models/io/json_fields.h"
#include "models/io/number_text.h"
#include "models/io/roots_json.h"
#include "models/linear/frequency_response.h"
#include "models/linear/linear_model.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The LQ weight on the model output (the CLI's --R0 default; the API exposes R only).
constexpr double kLqR0 = 20.0;
// Uniform-noise samples behind the LQ design's max_input_noise figure.
constexpr Eigen::Index kLqNoiseSamples = 20000;

json design_lq_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  require_stored_model(r, "plant_model", true, {"linear"}, env);
  const json* weight = r.member("r");
  const bool weight_given = weight != nullptr && !weight->is_null();
  r.number("r", 1e-5, {0.0, std::numeric_limits<double>::infinity(), true, true});
  // The weight chosen by its safe program amplitude instead (models::design_lq_for_input).
  if (const json* target = r.member("max_input"); target != nullptr && !target->is_null()) {
    if (weight_given) refuse(r.path_of("max_input"), "choose the weight by r or by max_input, not both");
    r.number("max_input", 0.0, {0.0, 1.0, true, false});
  }
  const json* band = r.member("band_pass");
  ParamReader b(band != nullptr ? *band : json::object(), r.path_of("band_pass"));
  const double low = b.number("low_hz", 20.0, {0.0, std::numeric_limits<double>::infinity(), false, true});
  b.number("high_hz", 1200.0, {low, env.fs / 2.0, true, true});
  b.integer("order", 2, 1, 16);
  r.set("band_pass", b.finish());
  return r.finish();
}

json design_lq_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const std::string plant_id = params.at("plant_model").get<std::string>();
  progress.at(0.0, "reading " + plant_id);
  const models::LinearModel model = models::linear_model_from_json(stored_model_file(env, plant_id));
  const json& band = params.at("band_pass");
  const double lo = band.at("low_hz").get<double>(), hi = band.at("high_hz").get<double>();
  const int band_order = band.at("order").get<int>();
  if (!(hi < model.fs / 2.0)) {
    throw std::invalid_argument("params.band_pass.high_hz: " + models::number_text(hi, 4) +
                                " Hz is not below the model's Nyquist frequency");
  }
  const std::vector<dsp::Biquad> band_pass = dsp::butterworth_band(band_order, lo, hi, model.fs);

  const std::uint64_t seed = 1;
  models::LqFeedforward ff;
  models::InputLimits limits;
  json search = nullptr;
  if (params.contains("max_input")) {
    const double target = params.at("max_input").get<double>();
    progress.at(0.1, "searching R for a safe program amplitude of " + models::number_text(target, 4));
    models::LqWeightSearch found = models::design_lq_for_input(model, kLqR0, target, band_pass, kLqNoiseSamples, seed);
    ff = std::move(found.ff);
    limits = found.limits;
    search = models::lq_weight_search_report(found);
  } else {
    progress.at(0.1, "LQ design, R = " + models::number_text(params.at("r").get<double>(), 4));
    ff = models::design_lq(model, {params.at("r").get<double>(), kLqR0});
    progress.at(0.4, "largest safe program amplitude");
    limits = models::max_input(ff, band_pass, kLqNoiseSamples, seed);
  }
  const double r_weight = ff.weights.R;
  const models::DrivePeak peak = models::drive_peak(ff, band_pass);
  ff.meta = {{"model", plant_id},
             {"model_method", model.method},
             {"order", ff.plant.order()},
             {"weights", {{"R", r_weight}, {"R0", kLqR0}}},
             {"bandpass", {lo, hi}},
             {"bandpass_order", band_order},
             {"max_input", {{"worst", limits.worst}, {"noise", limits.noise}, {"samples", kLqNoiseSamples}, {"seed", seed}}}};
  if (!search.is_null()) ff.meta["R_search"] = search;
  progress.at(0.8, "storing the controller");
  const std::string name = "lq R=" + models::number_text(r_weight, 4) + " on " + plant_id + " (" + control.job_id() + ")";
  const std::string model_id = store_model(env, models::lq_feedforward_to_json(ff), name, control);

  const Eigen::VectorXd f = dsp::log_spaced(10.0, 0.49 * ff.fs, 200);
  const Eigen::VectorXcd poles = ff.poles();
  json result = {{"model_id", model_id},
                 {"j_est_pct", nullptr},
                 {"j_val_pct", nullptr},
                 {"summary",
                  {{"plant_model", plant_id},
                   {"order", ff.plant.order()},
                   {"R", r_weight},
                   {"R_search", search},
                   {"R0", kLqR0},
                   {"L", models::to_array(ff.L.transpose())},
                   {"poles", models::roots_json(poles)},
                   {"zeros", models::roots_json(ff.zeros())},
                   {"pole_radius", poles.size() ? poles.cwiseAbs().maxCoeff() : 0.0},
                   {"bandpass", {lo, hi}},
                   {"bandpass_order", band_order},
                   {"max_input_worst", limits.worst},
                   {"max_input_noise", limits.noise},
                   {"drive_peak", {{"frequency_hz", peak.frequency_hz}, {"gain_db", peak.gain_db}}},
                   {"unity_gain_hz", models::unity_gain_hz(ff)}}},
                 {"plots",
                  {{"spectrum",
                    {{"f", column(f)},
                     {"plant_db", column(dsp::magnitude_db(models::frequency_response(ff.plant, f, ff.fs)))},
                     {"controlled_db", column(dsp::magnitude_db(models::frequency_response(ff.desired(), f, ff.fs)))},
                     {"controller_db", column(dsp::magnitude_db(models::frequency_response(ff.controller(), f, ff.fs)))}}}}}};
  progress.at(1.0, "done");
  return result;
}

}  // namespace

JobKind design_lq_job() { return {"design-lq", design_lq_params, design_lq_work}; }

}  // namespace panelbass::api

#include "api/jobs/identify_linear_job.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/model_judgement.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/record_acquisition.h"
#include "api/jobs/stored_models.h"
#include "dsp/leaky_integral.h"
#include "models/io/json_fields.h"
#include "models/io/roots_json.h"
#include "models/kinds/model_file.h"
#include "models/linear/data_survey.h"
#include "models/linear/fit_warnings.h"
#include "models/linear/linear_identification.h"
#include "models/linear/linear_model.h"
#include "models/preprocess/scaling.h"
#include "models/validation/performance.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// FIR taps go further than the orders of the other methods.
constexpr long long kMaxFirTaps = 2000;

json identify_linear_params(const json& params, const JobEnvironment& env) {
  ParamReader r(params, "params");
  std::string validation_path;
  const long long validation = record_source(r, env, validation_path);
  const std::string method = r.choice("method", "oe", {"fir", "arx", "oe", "zhu", "backx"});
  r.integer("order", 8, 1, method == "fir" ? kMaxFirTaps : kMaxOrder);
  r.integer("delay", -1, -1, 1000);
  const json* scan = r.member("scan");
  if (scan == nullptr || scan->is_null()) {
    r.set("scan", nullptr);
  } else {
    const std::vector<long long> range = r.integers("scan", {}, 2, 2, 1, kMaxOrder);
    if (range[0] > range[1]) refuse(r.path_of("scan"), "expected [from, to] with from <= to, got " + shown(*scan));
    if (validation == 0) refuse(r.path_of("scan"), "an order scan needs validation data (" + validation_path + " has none)");
  }
  r.integer("max_iterations", 100, 1, kMaxIterations);
  r.choice("process", "with_converters", {"with_converters", "alone"});
  return r.finish();
}

// The record with the converters' output as its drive (ExcitationRecord::l_est/l_val); throws naming what is
// missing when the record has none.
ExcitationRecord process_record(const SourcedRecord& data) {
  ExcitationRecord r = data.record;
  if (r.l_est.size() == 0) {
    throw std::runtime_error("params.process: \"alone\" needs the drive as the converters delivered it, and " +
                             data.source + " has none (on a sound card: serve --loopback-channel)");
  }
  r.u_est = r.l_est;
  r.u_val = r.l_val;
  return r;
}

// The process alone is fitted from the loopback l(k) to the sensor y(k − kAloneLagSamples), with one prefilter
// on both signals.
// Both found on the virtual transducer, whose converters are known exactly and whose loopback-to-sensor ratio,
// measured with sines, is its mechanics and sensor in closed form to 0.05 dB (20–1000 Hz) — while an
// unweighted OE(8) from the loopback was +1.0 / −5.9 / −1.9 / −0.8 dB off at 20 / 40 / 60 / 80 Hz:
// - The loopback's samples do not say what the converters' output did between them, and the sensor's samples
//   depend on it: the relation from the loopback to the sensor interpolates between loopback samples, the
//   ones after k as well as before (near fs/2 it is the inverse of the converters' sampling zeros, outside the
//   unit circle), which no causal model from l(k) to y(k) holds — the unweighted fit left J 0.18 % noise-free,
//   against 0.0007 % for the model with the converters. Fitted from l(k) to y(k − 4) it holds it (J 0.01 %);
//   the stored model is then the process alone with 4 samples more delay (its magnitude the process's).
// - An accelerometer's output falls as f² below the first resonance (at 20 Hz it is 55 dB under it), so an
//   unweighted output error gives the low end no share. One leaky integrator with its corner at fs/60 (50 Hz
//   at 3000 Hz) on both signals gives it back: the same filter on input and output leaves the process as it
//   is and weights the output error by its square (Ljung, System Identification, §14.4).
// Neither a longer record (20000 samples), a higher order (10, 12), ARX, nor either change alone met 1 dB at
// 20 Hz; both together: within 0.5 dB over 20–1000 Hz at every seed tried (six), J 0.01 %.
constexpr Eigen::Index kAloneLagSamples = 4;
constexpr double kAloneWeightCornerShare = 1.0 / 60.0;  // the leaky integrator's corner, a share of fs

// `x` less `mean`, through the leaky integrator (from rest).
Eigen::VectorXd weighted(const Eigen::VectorXd& x, double mean, double fs) {
  if (x.size() == 0) return x;
  const Eigen::VectorXd centred = x.array() - mean;
  return dsp::leaky_integral(centred, fs, kAloneWeightCornerShare * fs);
}

// The record from the loopback l(k) to the sensor y(k − kAloneLagSamples): each part's first samples of l and
// last of y dropped (an empty part stays empty).
ExcitationRecord lagged(const ExcitationRecord& r) {
  ExcitationRecord out = r;
  const auto shift = [](const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::VectorXd& u_out, Eigen::VectorXd& y_out) {
    const Eigen::Index n = std::max<Eigen::Index>(0, u.size() - kAloneLagSamples);
    u_out = u.size() > 0 ? Eigen::VectorXd(u.tail(n)) : u;
    y_out = y.size() > 0 ? Eigen::VectorXd(y.head(n)) : y;
  };
  shift(r.u_est, r.y_est, out.u_est, out.y_est);
  shift(r.u_val, r.y_val, out.u_val, out.y_val);
  return out;
}

// Identifies the process alone from `r` (its drive the loopback's, lagged()) with the weighting above; the
// model's offsets and J are those of `r` itself, unweighted.
models::LinearIdentification identify_process_alone(const ExcitationRecord& r, const models::LinearIdentificationSpec& spec) {
  const double u_mean = r.u_est.mean(), y_mean = r.y_est.mean();
  models::LinearIdentification id =
      models::identify_linear(weighted(r.u_est, u_mean, spec.fs), weighted(r.y_est, y_mean, spec.fs),
                              weighted(r.u_val, u_mean, spec.fs), weighted(r.y_val, y_mean, spec.fs), spec);
  // The weighting leaves the process's transfer function as it is; its offsets are the record's.
  id.model.scaling.u_offset = u_mean;
  id.model.scaling.y_offset = y_mean;
  const Eigen::Index init_est = std::min<Eigen::Index>(spec.init, r.u_est.size() / 10);
  id.j_est_pct = models::simulation_j_percent(id.model, r.u_est, r.y_est, init_est);
  id.j_pred_est_pct = models::j_percent(id.model.predict(r.u_est, r.y_est), r.y_est, init_est);
  if (r.u_val.size() > 0) id.j_val_pct = models::simulation_j_percent(id.model, r.u_val, r.y_val, spec.init);
  return id;
}

// What to try when a linear fit is no better than an output of zero.
std::string linear_advice(const models::LinearIdentification& id) {
  return "Check the delay (delay = " + std::to_string(id.model.tf.nk) + ", " + id.nk_source +
         "); then try another method (oe, zhu, backx), an order scan, or more max_iterations.";
}

json identify_linear_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const SourcedRecord data = acquire_record(params, env, progress, control);
  // The process alone (the thesis's fig. 3.6, §4): its input is the drive as the converters delivered it —
  // the drive prefiltered by the converters' response, which the loopback channel measured.
  const bool alone = params.at("process").get<std::string>() == "alone";
  const ExcitationRecord r = alone ? lagged(process_record(data)) : data.record;

  models::LinearIdentificationSpec spec;
  spec.method = models::parse_linear_method(params.at("method").get<std::string>());
  spec.order = params.at("order").get<int>();
  spec.delay = params.at("delay").get<int>();
  const bool scanning = params.at("scan").is_array();
  if (scanning) {
    spec.scan_from = params.at("scan")[0].get<int>();
    spec.scan_to = params.at("scan")[1].get<int>();
  }
  spec.init = kInit;
  spec.fs = env.fs;
  spec.oe.max_iterations = params.at("max_iterations").get<int>();

  // J per output-error iteration of the final fit: the OE loss (mean squared simulation error, scaled
  // units) over the mean square of the scaled output, the [2A] ratio from rest.
  const models::Scaling scaling = models::scaling_from_data(r.u_est, r.y_est);
  const double output_power = scaling.scale_y(r.y_est).squaredNorm() / static_cast<double>(r.y_est.size());
  const int fits = scanning ? spec.scan_to - spec.scan_from + 2 : 1;
  double base = 0.0;
  std::vector<HistoryPoint> history;
  const std::string method = params.at("method").get<std::string>();
  progress.span(kExcitationShare, 0.9);
  spec.progress = [&](const std::string& stage, double f) {
    if (f == 0.0 || stage == "scan") history.clear();  // a fit starts; the last one's iterations are kept
    base = models::identification_fraction(spec, stage, stage == "fit" ? 0.0 : f);  // a fit's iterations add to it
    progress.at(base, method + ": " + stage);
  };
  spec.oe.progress = [&](int iteration, double loss) {
    history.push_back({iteration, output_power > 0.0 ? 100.0 * loss / output_power : kNaN, kNaN});
    progress.at(base + static_cast<double>(iteration) / spec.oe.max_iterations / fits,
                method + " iteration " + std::to_string(iteration));
  };
  models::LinearIdentification id =
      alone ? identify_process_alone(r, spec) : models::identify_linear(r.u_est, r.y_est, r.u_val, r.y_val, spec);

  progress.span(0.9, 1.0);
  progress.at(0.0, "storing the model");
  id.model.meta = {{"data", data.source + " (estimation)"},
                   {"val", r.u_val.size() ? json(data.source + " (validation)") : json("")},
                   {"na", id.model.tf.na()},
                   {"nb", id.model.tf.nb()},
                   {"nk", id.model.tf.nk},
                   {"J_est_pct", id.j_est_pct},
                   {"J_val_pct", models::number_or_null(id.j_val_pct)},
                   {"process", alone ? "alone: the input is the drive as the converters delivered it (loopback), the "
                                       "converters left out; fitted from l(k) to y(k - 4) (the model carries 4 samples more delay than the "
                                       "process) and weighted toward the low end"
                                     : "with_converters: the input is the drive, the converters included"}};
  const int order = id.model.tf.na() > 0 ? id.model.tf.na() : id.model.tf.nb();
  const std::string model_id = store_model(env, models::linear_model_to_json(id.model),
                                           method + " order " + std::to_string(order) + " (" + control.job_id() + ")", control);

  const std::string history_source = history.empty() ? "the final model" : "output-error iterations of the final fit (from rest)";
  if (history.empty()) history.push_back({0, id.j_est_pct, id.j_val_pct});
  json summary = {{"method", method},
                  {"order", order},
                  {"na", id.model.tf.na()},
                  {"nb", id.model.tf.nb()},
                  {"delay", id.model.tf.nk},
                  {"nk_source", id.nk_source},
                  {"J_pred_est_pct", id.j_pred_est_pct},
                  {"poles", models::roots_json(id.model.tf.poles())},
                  {"zeros", models::roots_json(id.model.tf.zeros())},
                  {"survey", models::data_survey_to_json(id.survey)},
                  {"data", data.source},
                  {"process", params.at("process")},
                  {"history_source", history_source}};
  if (!id.scan.empty()) {
    json scan = json::array();
    for (const auto& e : id.scan) scan.push_back({{"order", e.order}, {"J_est_pct", e.j_est_pct}, {"J_val_pct", e.j_val_pct}});
    summary["scan"] = scan;
    summary["order_rule"] = id.order_rule;
    summary["scan_skipped"] = id.scan_skipped;
  }
  const models::AnyModel any{id.model};
  json plots = model_plots(any, r, env.fs);
  plots["history"] = history_plot(history);
  progress.at(1.0, "done");
  const bool validated = r.u_val.size() > 0;
  return {{"model_id", model_id},
          {"j_est_pct", id.j_est_pct},
          {"j_val_pct", models::number_or_null(id.j_val_pct)},
          {"summary", summary},
          {"plots", plots},
          {"warnings", models::fit_warnings(validated ? id.j_val_pct : id.j_est_pct, validated ? "J_val" : "J_est",
                                            kNaN, linear_advice(id))}};
}

}  // namespace

JobKind identify_linear_job() { return {"identify-linear", identify_linear_params, identify_linear_work}; }

}  // namespace panelbass::api

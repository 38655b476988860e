#include "usecases/identify_linear.h"

#include <algorithm>
#include <limits>
#include <string>

#include "models/io/json_fields.h"
#include "models/io/roots_json.h"
#include "models/linear/data_survey.h"
#include "models/linear/fit_warnings.h"
#include "models/linear/linear_identification.h"
#include "models/linear/process_alone.h"
#include "models/preprocess/scaling.h"
#include "models/validation/performance.h"
#include "usecases/request_checks.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

const std::vector<std::string> kMethods{"fir", "arx", "oe", "zhu", "backx"};

// The meta's words for how the model's input relates to the process.
std::string process_text(bool alone) {
  return alone ? "alone: the input is the drive as the converters delivered it (loopback), the converters left out; "
                 "fitted from l(k) to y(k - " + std::to_string(models::kProcessAloneLagSamples) +
                     ") (the model carries that many samples more delay than the process) and weighted toward the low end"
               : "with_converters: the input is the drive, the converters included";
}

}  // namespace

void check_scan(const std::vector<int>& scan, bool validated) {
  if (scan.empty()) return;
  if (scan.size() != 2 || scan[0] < 1 || scan[0] > scan[1] || scan[1] > kMaxLinearOrder) {
    std::string shown;
    for (const int s : scan) shown += (shown.empty() ? "" : ", ") + std::to_string(s);
    throw RequestError("scan", "expected [from, to] with 1 <= from <= to <= " + std::to_string(kMaxLinearOrder) +
                                   ", got [" + shown + "]");
  }
  if (!validated) throw RequestError("scan", "an order scan needs validation data: the order is picked by validation J");
}

void check(const IdentifyLinearRequest& q) {
  if (std::find(kMethods.begin(), kMethods.end(), q.method) == kMethods.end()) {
    throw RequestError("method", "must be fir, arx, oe, zhu or backx, got \"" + q.method + "\"");
  }
  within("order", q.order, 1, q.method == "fir" ? kMaxFirTaps : kMaxLinearOrder);
  within("delay", q.delay, -1, 100000);
  within("init", q.init, 0, 1000000);
  within("decimation", q.decimation, 1, 64);
  within("max_iterations", q.max_iterations, 1, 100000);
  if (q.process != "with_converters" && q.process != "alone") {
    throw RequestError("process", "must be with_converters or alone, got \"" + q.process + "\"");
  }
  const bool records = q.u_est.size() > 0;
  check_scan(q.scan, !records || q.u_val.size() > 0);
  if (!records) return;
  if (q.u_est.size() != q.y_est.size() || q.u_val.size() != q.y_val.size()) {
    throw RequestError("record", "a part's drive and response differ in length");
  }
}

nlohmann::json to_json(const IdentifyLinearRequest& q) {
  return {{"record", q.data_name},   {"method", q.method},
          {"order", q.order},        {"delay", q.delay},
          {"scan", q.scan.empty() ? nlohmann::json(nullptr) : nlohmann::json(q.scan)},
          {"init", q.init},          {"decimation", q.decimation},
          {"max_iterations", q.max_iterations}, {"process", q.process}};
}

IdentifyLinearReport identify_linear(const IdentifyLinearRequest& q, Progress& progress) {
  check(q);
  if (q.u_est.size() == 0) throw RequestError("record", "no estimation samples");
  const bool alone = q.process == "alone";
  // The process alone: the loopback l(k) against the sensor y(k − lag) (an empty part stays empty).
  const models::LoopbackPair est = alone ? models::process_alone_pair(q.u_est, q.y_est) : models::LoopbackPair{q.u_est, q.y_est};
  const models::LoopbackPair val = alone ? models::process_alone_pair(q.u_val, q.y_val) : models::LoopbackPair{q.u_val, q.y_val};

  models::LinearIdentificationSpec spec;
  spec.method = models::parse_linear_method(q.method);
  spec.order = q.order;
  spec.delay = q.delay;
  if (!q.scan.empty()) {
    spec.scan_from = q.scan[0];
    spec.scan_to = q.scan[1];
  }
  spec.init = q.init;
  spec.fs = q.fs;
  spec.decimation = q.decimation;
  spec.oe.max_iterations = q.max_iterations;

  // J per output-error iteration of the final fit: the OE loss (mean squared simulation error, scaled units) over
  // the mean square of the scaled output, the [2A] ratio from rest.
  const models::Scaling scaling = models::scaling_from_data(est.l, est.y);
  const double output_power = scaling.scale_y(est.y).squaredNorm() / static_cast<double>(est.y.size());
  const int fits = q.scan.empty() ? 1 : q.scan[1] - q.scan[0] + 2;
  double base = 0.0;
  IdentifyLinearReport report;
  spec.progress = [&](const std::string& stage, double f) {
    if (f == 0.0 || stage == "scan") report.history.clear();  // a fit starts; the last one's iterations are kept
    base = models::identification_fraction(spec, stage, stage == "fit" ? 0.0 : f);  // a fit's iterations add to it
    progress.report(base, q.method + ": " + stage);
  };
  spec.oe.progress = [&](int iteration, double loss) {
    report.history.push_back({iteration, models::j_ratio_percent(loss, output_power)});
    progress.report(std::min(1.0, base + static_cast<double>(iteration) / spec.oe.max_iterations / fits),
                    q.method + " iteration " + std::to_string(iteration));
  };
  models::LinearIdentification id =
      alone ? models::identify_process_alone(est, val, spec) : models::identify_linear(est.l, est.y, val.l, val.y, spec);

  const int order = id.model.tf.na() > 0 ? id.model.tf.na() : id.model.tf.nb();
  id.model.meta = {{"data", q.data_name},
                   {"val", q.val_name},
                   {"na", id.model.tf.na()},
                   {"nb", id.model.tf.nb()},
                   {"nk", id.model.tf.nk},
                   {"J_est_pct", id.j_est_pct},
                   {"J_val_pct", models::number_or_null(id.j_val_pct)},
                   {"process", process_text(alone)}};
  report.summary = {{"method", q.method},
                    {"order", order},
                    {"na", id.model.tf.na()},
                    {"nb", id.model.tf.nb()},
                    {"J_est_pct", id.j_est_pct},
                    {"J_val_pct", models::number_or_null(id.j_val_pct)},
                    {"J_pred_est_pct", id.j_pred_est_pct},
                    {"delay", id.model.tf.nk},
                    {"nk_source", id.nk_source},
                    {"poles", models::roots_json(id.model.tf.poles())},
                    {"zeros", models::roots_json(id.model.tf.zeros())},
                    {"survey", models::data_survey_to_json(id.survey)},
                    {"process", q.process}};
  if (!id.scan.empty()) {
    nlohmann::json scan = nlohmann::json::array();
    for (const auto& e : id.scan) scan.push_back({{"order", e.order}, {"J_est_pct", e.j_est_pct}, {"J_val_pct", e.j_val_pct}});
    report.summary["scan"] = scan;
    report.summary["order_rule"] = id.order_rule;
    report.summary["scan_skipped"] = id.scan_skipped;
  }
  const bool validated = val.l.size() > 0;
  report.warnings = models::fit_warnings(
      validated ? id.j_val_pct : id.j_est_pct, validated ? "J_val" : "J_est", std::numeric_limits<double>::quiet_NaN(),
      "Check the delay (delay " + std::to_string(id.model.tf.nk) + ", " + id.nk_source +
          "); then try another method (oe, zhu, backx), an order scan, or more iterations (max_iterations).");
  report.model = std::move(id.model);
  progress.report(1.0, "done");
  return report;
}

}  // namespace panelbass::usecases

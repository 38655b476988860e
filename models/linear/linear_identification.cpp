#include "models/linear/linear_identification.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "models/linear/arx_estimator.h"
#include "models/linear/backx_estimator.h"
#include "models/linear/estimation_error.h"
#include "models/linear/fir_estimator.h"
#include "models/validation/performance.h"
#include "models/linear/zhu_estimator.h"

namespace panelbass::models {
namespace {

constexpr double kScanTolerance = 0.05;  // an order within 5 % of the best validation J is good enough

TransferFunction estimate_scaled(const Eigen::VectorXd& u, const Eigen::VectorXd& y, int order, int nk,
                                 const LinearIdentificationSpec& spec) {
  const ModelOrders orders{spec.method == LinearMethod::fir ? 0 : order, order, nk};
  switch (spec.method) {
    case LinearMethod::fir: {
      // An FIR with the delay: taps b_0..b_{order−1} on u(k−nk).
      const Eigen::Index n = u.size() - nk;
      if (n <= 0) throw EstimationError("FIR: the delay is longer than the record");
      TransferFunction tf;
      tf.b = estimate_fir(u.head(n), y.tail(n), order);
      tf.nk = nk;
      return tf;
    }
    case LinearMethod::arx:
      return estimate_arx(u, y, orders);
    case LinearMethod::oe:
      return estimate_oe(u, y, stabilized(estimate_arx(u, y, orders)), spec.oe).tf;
    case LinearMethod::zhu: {
      ZhuOptions options;
      options.oe = spec.oe;
      return estimate_zhu(u, y, orders, options).tf;
    }
    case LinearMethod::backx: {
      BackxOptions options;
      options.decimation = spec.decimation;
      options.oe = spec.oe;
      return estimate_backx(u, y, orders, spec.fs, options).tf;
    }
  }
  throw std::logic_error("unknown linear method");
}

void require_finite(const Eigen::VectorXd& x, const char* what) {
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    if (!std::isfinite(x[k])) throw std::invalid_argument(std::string(what) + ": sample " + std::to_string(k) + " is not finite");
  }
}

}  // namespace

LinearMethod parse_linear_method(const std::string& name) {
  for (LinearMethod m : {LinearMethod::fir, LinearMethod::arx, LinearMethod::oe, LinearMethod::zhu, LinearMethod::backx}) {
    if (to_string(m) == name) return m;
  }
  throw std::invalid_argument("unknown method \"" + name + "\" (fir, arx, oe, zhu, backx)");
}

std::string to_string(LinearMethod method) {
  switch (method) {
    case LinearMethod::fir: return "fir";
    case LinearMethod::arx: return "arx";
    case LinearMethod::oe: return "oe";
    case LinearMethod::zhu: return "zhu";
    case LinearMethod::backx: return "backx";
  }
  return "?";
}

double simulation_j_percent(const LinearModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                            Eigen::Index init) {
  const Eigen::VectorXd y_model = model.simulate(u, y, init);
  return j_percent(y_model, y, init);
}

double identification_fraction(const LinearIdentificationSpec& spec, const std::string& stage, double fraction) {
  const int fits = spec.scan_to > 0 ? spec.scan_to - spec.scan_from + 2 : 1;  // each scanned order, then the fit
  const double share = 1.0 / fits, f = std::clamp(fraction, 0.0, 1.0);
  if (stage == "scan") return f * (fits - 1) * share;
  if (stage == "fit") return (fits - 1) * share + f * share;
  return 0.0;
}

LinearIdentification identify_linear(const Eigen::VectorXd& u_est, const Eigen::VectorXd& y_est,
                                     const Eigen::VectorXd& u_val, const Eigen::VectorXd& y_val,
                                     const LinearIdentificationSpec& spec) {
  require_finite(u_est, "estimation input");
  require_finite(y_est, "estimation output");
  require_finite(u_val, "validation input");
  require_finite(y_val, "validation output");
  if (u_val.size() != y_val.size()) throw std::invalid_argument("validation input and output lengths differ");
  if (!(spec.fs > 0.0)) throw std::invalid_argument("the sample rate must be > 0");
  const bool have_val = u_val.size() > 0;
  const bool scanning = spec.scan_to > 0;
  if (scanning && !have_val) throw std::invalid_argument("an order scan needs validation data (--val)");
  if (scanning && (spec.scan_from < 1 || spec.scan_from > spec.scan_to)) {
    throw std::invalid_argument("order scan " + std::to_string(spec.scan_from) + ":" + std::to_string(spec.scan_to) +
                                " is empty or starts below 1");
  }
  if (!scanning && spec.order < 1) throw std::invalid_argument("order must be >= 1");
  if (have_val && spec.init >= u_val.size()) throw std::invalid_argument("--init is longer than the validation data");

  LinearIdentification out;
  if (spec.progress) spec.progress("survey", 0.0);
  out.survey = survey_data(u_est, y_est);
  const Scaling& scaling = out.survey.scaling;
  const int nk = spec.delay >= 0 ? spec.delay : out.survey.delay;
  out.nk_source = spec.delay >= 0 ? "given" : delay_finding(out.survey);
  const Eigen::VectorXd us = scaling.scale_u(u_est), ys = scaling.scale_y(y_est);

  auto make_model = [&](int order, int delay) {
    LinearModel m;
    m.tf = estimate_scaled(us, ys, order, delay, spec);
    if (!m.tf.all_finite()) throw EstimationError(to_string(spec.method) + ": the fit produced non-finite coefficients");
    if (!m.tf.is_stable()) {
      throw EstimationError(to_string(spec.method) + " at order " + std::to_string(order) +
                            " gave an unstable model; try oe, zhu or backx, or a lower order");
    }
    m.fs = spec.fs;
    m.scaling = scaling;
    m.method = to_string(spec.method);
    return m;
  };

  int order = spec.order;
  if (scanning) {
    for (int n = spec.scan_from; n <= spec.scan_to; ++n) {
      if (spec.progress) spec.progress("scan", static_cast<double>(n - spec.scan_from) / (spec.scan_to - spec.scan_from + 1));
      LinearModel m;
      try {
        m = make_model(n, nk);
      } catch (const EstimationError& e) {
        // An order the data cannot support: skipped, unless none can be fitted at all.
        if (out.scan.empty() && n == spec.scan_to) throw;
        out.scan_skipped.push_back("order " + std::to_string(n) + ": " + e.what());
        continue;
      }
      out.scan.push_back({n, simulation_j_percent(m, u_est, y_est, std::min<Eigen::Index>(spec.init, u_est.size() / 10)),
                          simulation_j_percent(m, u_val, y_val, spec.init)});
    }
    double best = out.scan.front().j_val_pct;
    for (const auto& e : out.scan) best = std::min(best, e.j_val_pct);
    for (const auto& e : out.scan) {
      if (e.j_val_pct <= (1.0 + kScanTolerance) * best) {
        order = e.order;
        break;
      }
    }
    out.order_rule = "smallest order whose validation J is within 5 % of the best (" + std::to_string(best) + " %)";
  }
  if (spec.progress) spec.progress("fit", 0.0);
  out.model = make_model(order, nk);
  const Eigen::Index init_est = std::min<Eigen::Index>(spec.init, u_est.size() / 10);
  // The first significant tap sits at a threshold: record noise can move a slow rise's onset one lag early,
  // and a local fit (OE) from there may stop worse than from the true dead time. So an estimated delay is
  // fitted one lag later too, and the fit with the lower J (validation, else estimation) is kept.
  if (spec.delay < 0 && out.survey.delay_found) {
    auto j_of = [&](const LinearModel& m) {
      return have_val ? simulation_j_percent(m, u_val, y_val, spec.init) : simulation_j_percent(m, u_est, y_est, init_est);
    };
    try {
      LinearModel later = make_model(order, nk + 1);
      const double j_first = j_of(out.model), j_later = j_of(later);
      const bool keep_later = j_later < j_first;
      out.nk_source += "; lag " + std::to_string(nk + 1) + " fitted too (J " + std::to_string(j_later) + " % against " +
                       std::to_string(j_first) + " %), " + (keep_later ? "kept" : "not kept");
      if (keep_later) out.model = std::move(later);
    } catch (const EstimationError& e) {
      out.nk_source += "; lag " + std::to_string(nk + 1) + " could not be fitted (" + e.what() + ")";
    }
  }
  out.j_est_pct = simulation_j_percent(out.model, u_est, y_est, init_est);
  out.j_pred_est_pct = j_percent(out.model.predict(u_est, y_est), y_est, init_est);
  if (have_val) out.j_val_pct = simulation_j_percent(out.model, u_val, y_val, spec.init);
  if (spec.progress) spec.progress("fit", 1.0);
  return out;
}

}  // namespace panelbass::models

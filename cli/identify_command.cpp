#include <cmath>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/json_output.h"
#include "cli/progress_bar.h"
#include "models/linear_identification.h"

namespace panelbass::cli {
namespace {

struct IdentifyLinearOptions {
  std::string data, val, out;
  DataOptions columns;
  std::string method = "zhu";
  int order = 8;
  int delay = -1;
  std::string scan;
  long init = 50;
  int decimation = 1;
  int max_iterations = 100;
};

nlohmann::json poles_json(const models::TransferFunction& tf) {
  nlohmann::json poles = nlohmann::json::array();
  const Eigen::VectorXcd p = tf.poles();
  for (Eigen::Index k = 0; k < p.size(); ++k) poles.push_back({p[k].real(), p[k].imag()});
  return poles;
}

nlohmann::json number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

void run_identify_linear(const IdentifyLinearOptions& o) {
  const dsp::Record est = o.columns.read(o.data);
  models::LinearIdentificationSpec spec;
  spec.method = models::parse_linear_method(o.method);
  spec.order = o.order;
  spec.delay = o.delay;
  spec.init = o.init;
  spec.fs = est.fs;
  spec.decimation = o.decimation;
  spec.oe.max_iterations = o.max_iterations;
  if (!o.scan.empty()) {
    const auto colon = o.scan.find(':');
    if (colon == std::string::npos) throw std::invalid_argument("--scan expects FROM:TO, got \"" + o.scan + "\"");
    spec.scan_from = std::stoi(o.scan.substr(0, colon));
    spec.scan_to = std::stoi(o.scan.substr(colon + 1));
  }
  Eigen::VectorXd u_val, y_val;
  if (!o.val.empty()) {
    const dsp::Record val = o.columns.read(o.val);
    if (val.fs != est.fs) throw std::invalid_argument(o.val + ": sample rate differs from the estimation data");
    u_val = val.columns[0];
    y_val = val.columns[1];
  }
  ProgressBar bar("identify " + o.method);
  spec.progress = [&bar](const std::string&, double f) { bar.update(f); };
  models::LinearIdentification id = models::identify_linear(est.columns[0], est.columns[1], u_val, y_val, spec);
  bar.update(1.0);

  nlohmann::json scan = nlohmann::json::array();
  for (const auto& e : id.scan) scan.push_back({{"order", e.order}, {"J_est_pct", e.j_est_pct}, {"J_val_pct", e.j_val_pct}});
  id.model.meta = {{"data", o.data},
                   {"val", o.val},
                   {"na", id.model.tf.na()},
                   {"nb", id.model.tf.nb()},
                   {"nk", id.model.tf.nk},
                   {"J_est_pct", id.j_est_pct},
                   {"J_val_pct", number_or_null(id.j_val_pct)}};
  models::save_linear_model(o.out, id.model);

  nlohmann::json result = {{"method", o.method},
                           {"order", id.model.tf.na() > 0 ? id.model.tf.na() : id.model.tf.nb()},
                           {"J_est_pct", id.j_est_pct},
                           {"J_val_pct", number_or_null(id.j_val_pct)},
                           {"J_pred_est_pct", id.j_pred_est_pct},
                           {"delay", id.model.tf.nk},
                           {"poles", poles_json(id.model.tf)},
                           {"survey", models::data_survey_to_json(id.survey)},
                           {"out", o.out}};
  if (!id.scan.empty()) {
    result["scan"] = scan;
    result["order_rule"] = id.order_rule;
  }
  print_result(result);
}

}  // namespace

void register_identify(CLI::App& app) {
  CLI::App* identify = app.add_subcommand("identify", "Identify a model from measured data");
  identify->require_subcommand(1);
  identify->footer("Example:\n  panelbass identify linear --data est.csv --val val.csv --fs 3000 --method zhu --order 8 --out lin.json");

  auto o = std::make_shared<IdentifyLinearOptions>();
  CLI::App* linear = identify->add_subcommand("linear", "Linear model by FIR, ARX, OE, Zhu's method or FIR-Hankel-OE (Backx)");
  linear->add_option("--data", o->data, "Estimation data, .csv or .wav")->required();
  linear->add_option("--val", o->val, "Validation data (for J_val and --scan)");
  o->columns.add_to(linear);
  linear->add_option("--method", o->method, "fir, arx, oe, zhu or backx")
      ->check(CLI::IsMember({"fir", "arx", "oe", "zhu", "backx"}))
      ->capture_default_str();
  linear->add_option("--order", o->order, "Model order (na = nb; FIR: taps)")->check(CLI::Range(1, 5000))->capture_default_str();
  linear->add_option("--delay", o->delay, "Input delay nk in samples (default: estimated)")->check(CLI::Range(0, 100000));
  linear->add_option("--scan", o->scan, "Order scan FROM:TO, e.g. 1:16 (keeps the order the rule picks)");
  linear->add_option("--init", o->init, "Measured outputs that set the state before J is computed")
      ->check(CLI::Range(0L, 1000000L))
      ->capture_default_str();
  linear->add_option("--decimate", o->decimation, "Backx: decimation factor before the FIR step")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  linear->add_option("--max-iter", o->max_iterations, "Output-error iterations")->check(CLI::Range(1, 100000))->capture_default_str();
  linear->add_option("--out", o->out, "Model file to write (JSON)")->required();
  linear->footer(
      "Example:\n  panelbass simulate --samples 12000 --out run.csv\n"
      "  panelbass identify linear --data run.csv --fs 3000 --method zhu --scan 1:12 --val run.csv --out lin.json");
  linear->callback([o] { run_identify_linear(*o); });
}

}  // namespace panelbass::cli

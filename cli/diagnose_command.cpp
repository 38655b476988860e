// `panelbass diagnose`: where a linear simulation and a recording disagree, the physics left out, that
// physics modelled, and validation J before and after (models/diagnosis/diagnosis.h does the work).

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/diagnosis_plots.h"
#include "cli/diagnosis_report.h"
#include "cli/gnuplot.h"
#include "cli/json_output.h"
#include "cli/report_output.h"
#include "cli/usecase_door.h"
#include "dsp/data_error.h"
#include "dsp/data_file.h"
#include "dsp/sample_rate.h"
#include "models/diagnosis/diagnosis.h"
#include "models/diagnosis/diagnosis_baselines.h"
#include "models/diagnosis/gray_box_model.h"
#include "models/io/json_file.h"
#include "models/linear/linear_model.h"
#include "models/kinds/model_file.h"
#include "models/plant/plant_config.h"
#include "usecases/diagnose.h"

namespace panelbass::cli {
namespace {

namespace fs = std::filesystem;

// The flags; the request's settings start at its defaults (usecases::DiagnoseRequest), the doors' one place for them.
struct DiagnoseOptions {
  std::vector<std::string> data, val;  ///< one pair per drive level (--data and --val repeated, in order)
  std::string model;
  DataOptions columns;
  ReportOutputOptions outputs;
  usecases::DiagnoseRequest settings;  ///< init, the scan, max_findings, sensor, use_current
  long window = 300;
  /// The coil current's column: "auto" (the request's use_current: "i" or "current" when both records have one) or
  /// "none" (docs/diagnosis.md: the current is better on both families).
  std::string current_col = usecases::DiagnoseRequest{}.use_current ? "auto" : "none";
  std::string model_out;  ///< the diagnosed model as a gray_box model file (empty: not written)
};

// The current column of `path` (samples at the record's rate), when --current-col names one or, with "auto", when
// the file has a column "i" or "current" (the virtual transducer writes u,y,i,x); empty with "none" or none found.
Eigen::VectorXd read_current(const std::string& path, const DataOptions& columns, double fs, const std::string& which) {
  if (which == "none") return {};
  const std::vector<std::string> names = which == "auto" ? std::vector<std::string>{"i", "current"} : std::vector<std::string>{which};
  for (const auto& name : names) {
    try {
      return dsp::read_data_file(path, {columns.input_col, name}, fs).columns[1];
    } catch (const dsp::DataError&) {
      if (which != "auto") throw;
    }
  }
  return {};
}

// The baseline --model names in the request: a linear model, or a simulation that is not linear (a NARX, ss,
// gray_box or oscillator model, a virtual-transducer plant JSON run without sensor noise); its rate.
double load_baseline(const std::string& path, usecases::DiagnoseRequest& q) {
  q.baseline_name = path;
  const nlohmann::json j = models::read_json_file(path);
  if (j.is_object() && j.contains("format") && j["format"].is_string() &&
      j["format"].get<std::string>().starts_with("panelbass.plant")) {
    q.simulation_baseline = models::plant_baseline(models::load_plant_file(path));
    return q.simulation_baseline->fs;
  }
  const models::AnyModel model = models::load_model(path);
  if (const auto* linear = std::get_if<models::LinearModel>(&model.model)) {
    q.linear_baseline = *linear;
    return linear->fs;
  }
  q.simulation_baseline = std::visit([&](const auto& m) { return models::model_baseline(model.kind(), m); }, model.model);
  return q.simulation_baseline->fs;
}

// The use case's stages on standard error, one line each.
class StageLines final : public usecases::Progress {
 public:
  void report(double, const std::string& message) override { std::cerr << "diagnose: " << message << std::endl; }
};

void run_diagnose(const DiagnoseOptions& o) {
  usecases::DiagnoseRequest q = o.settings;
  q.use_current = o.current_col != "none";
  DataOptions columns = o.columns;
  if (!o.model.empty()) {
    const double model_fs = load_baseline(o.model, q);
    if (!(columns.fs > 0.0)) columns.fs = model_fs;
  }
  if (o.data.size() != o.val.size())
    throw CLI::ValidationError("--val", "give one --val per --data (records at several levels come in pairs): " +
                                            std::to_string(o.data.size()) + " --data, " + std::to_string(o.val.size()) + " --val");
  const bool has_baseline = q.linear_baseline || q.simulation_baseline;
  const double baseline_fs = q.linear_baseline ? q.linear_baseline->fs : has_baseline ? q.simulation_baseline->fs : 0.0;
  const auto read = [&](const std::string& path) { return has_baseline ? columns.read_at_model_rate(path, baseline_fs) : columns.read(path); };
  // Records at several levels: the use case diagnoses the pair with the loudest drive (where a nonlinear effect
  // shows most); every other pair's validation part judges each finding at its own level.
  for (std::size_t k = 0; k < o.data.size(); ++k) {
    const dsp::Record est = read(o.data[k]);
    const dsp::Record val = read(o.val[k]);
    if (k == 0) q.fs = est.fs;
    if (!dsp::same_rate(val.fs, q.fs) || !dsp::same_rate(est.fs, q.fs))
      throw std::invalid_argument((dsp::same_rate(est.fs, q.fs) ? o.val[k] : o.data[k]) + ": sample rate " +
                                  std::to_string(dsp::same_rate(est.fs, q.fs) ? val.fs : est.fs) + " Hz differs from " +
                                  o.data[0] + "'s " + std::to_string(q.fs) + " Hz");
    usecases::DiagnoseLevel level{o.val[k], est.columns[0], est.columns[1], val.columns[0], val.columns[1], {}, {}};
    level.i_est = read_current(o.data[k], columns, est.fs, o.current_col);
    if (level.i_est.size() > 0) level.i_val = read_current(o.val[k], columns, val.fs, o.current_col);
    // Found by default in one record only: neither is used (a named column must be in both).
    if ((level.i_est.size() > 0) != (level.i_val.size() > 0) && o.current_col == "auto") level.i_est = level.i_val = Eigen::VectorXd();
    if ((level.i_est.size() > 0) != (level.i_val.size() > 0))
      throw dsp::DataError(o.val[k] + ": has no current column while " + o.data[k] + " has one (give --current-col none to leave it out)");
    q.levels.push_back(std::move(level));
  }
  // Everything that can be refused is refused before the work starts.
  RequestSpelling spelling;
  spelling.flags = {{"record", "--val"}, {"use_current", "--current-col"}};
  run_use_case([&] { usecases::check(q); }, spelling);
  const PlotFormat format = o.outputs.prepare();
  if (!o.model_out.empty() && q.simulation_baseline)
    throw std::invalid_argument("--model-out: the baseline " + o.model +
                                " is not a linear model; only a linear baseline with its gray-box terms is written as a model file");

  StageLines stages;
  const usecases::DiagnoseReport result = run_use_case([&] { return usecases::diagnose(q, stages); }, spelling);
  const models::Diagnosis& d = result.diagnosis;
  const std::size_t main = result.diagnosed_level;
  const usecases::DiagnoseLevel& val = q.levels[main];
  nlohmann::json report = result.report;
  report["data"] = o.data[main];
  report["val"] = o.val[main];
  if (o.data.size() > 1) {
    report["levels"] = nlohmann::json::array();
    for (std::size_t k = 0; k < o.data.size(); ++k)
      report["levels"].push_back({{"data", o.data[k]}, {"val", o.val[k]}, {"diagnosed", k == main}});
  }
  o.outputs.name_outputs(report);
  DiagnosisPlotOptions plot_options;
  plot_options.format = format;
  plot_options.window = o.window;
  o.outputs.draw_figures(
      "panelbass-diagnose", report,
      [&](const fs::path& dir) {
        stages.report(1.0, "drawing the figures");
        return plot_diagnosis(d, DiagnosisValidation{val.u_val, val.y_val, q.init}, dir, plot_options);
      },
      [&](const std::vector<ReportFigure>& figures) { write_diagnosis_html(o.outputs.html, report, figures, format); });
  if (!o.model_out.empty()) {
    models::write_json_file(o.model_out, result.model_file);
    report["model_out"] = o.model_out;
  }
  models::write_json_file(o.outputs.out, report);
  // stdout: the summary (the report file holds the evidence in full).
  nlohmann::json summary = {{"baseline", report["baseline"]},
                            {"channels", report["channels"]["used"]},
                            {"J_val_before_pct", d.j_val_before_pct},
                            {"J_val_after_pct", d.j_val_after_pct},
                            {"noise_floor_pct", d.noise_floor_pct},
                            {"at_noise_floor", report["at_noise_floor"]},
                            {"unexplained", report["unexplained"]},
                            {"out", o.outputs.out},
                            {"model_out", o.model_out.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.model_out)},
                            {"html", report["html"]},
                            {"plots", report["plots"]}};
  summary["baseline"].erase("scan");
  nlohmann::json findings = nlohmann::json::array();
  for (const auto& f : report["findings"])
    findings.push_back({{"effect", f["effect"]}, {"explanation", f["explanation"]}, {"confidence", f["confidence"]["sentence"]},
                        {"J_val_before_pct", f["J_val_before_pct"]}, {"J_val_after_pct", f["J_val_after_pct"]}});
  summary["findings"] = findings;
  print_result(summary);
}

}  // namespace

void register_diagnose(CLI::App& app) {
  auto o = std::make_shared<DiagnoseOptions>();
  CLI::App* cmd = app.add_subcommand(
      "diagnose", "Locate where a linear simulation and a recording disagree, name the physics left out, model it");
  cmd->add_option("--data", o->data,
                  "Estimation data, .csv or .wav; repeated (with one --val each) for records at several drive levels: the "
                  "loudest pair is diagnosed, the others' validation parts say whether each finding's gain grows with level")
      ->required();
  cmd->add_option("--val", o->val, "Validation data, .csv or .wav (judges every augmentation); one per --data")->required();
  o->columns.add_to(cmd);
  cmd->add_option("--model", o->model,
                  "Simulation to diagnose: a linear, NARX or neural state-space (ss) model file, or a plant JSON (default: the best OE model of the order scan)");
  cmd->add_option("--init", o->settings.init, "Measured outputs that set a simulation's state before J is computed")
      ->capture_default_str();
  cmd->add_option("--scan-from", o->settings.scan_from, "Without --model: lowest OE order scanned (1..60)")->capture_default_str();
  cmd->add_option("--scan-to", o->settings.scan_to, "Without --model: highest OE order scanned (1..60)")->capture_default_str();
  cmd->add_option("--max-findings", o->settings.max_findings, "Augmentation rounds at most (0..20)")->capture_default_str();
  cmd->add_option("--sensor", o->settings.sensor,
                  "What the output measures: displacement, velocity or acceleration (a spring and a damping then act on "
                  "the displacement and its rate of change, not on the cube of one signal); unknown tries every state")
      ->capture_default_str();
  cmd->add_option("--current-col", o->current_col,
                  "The coil current's column: it tells apart effects that look alike from the drive (a spring from a "
                  "damping, a coil offset from an asymmetric spring) and finds a second force beside the first; auto (the "
                  "default): \"i\" or \"current\" when both records have one; none: leave it out")
      ->capture_default_str();
  cmd->add_option("--model-out", o->model_out,
                  "Write the diagnosed model (the linear baseline with its gray-box terms) as a model file of kind gray_box, "
                  "which validate, simulate and analyze read (a linear baseline only)");
  o->outputs.add_to(cmd, "Report to write (JSON)", "Self-contained HTML report (findings, J per step, figures embedded)");
  cmd->add_option("--window", o->window, "Samples shown in the fit plot")->check(CLI::Range(2L, 100000000L))->capture_default_str();
  cmd->footer(
      "Each candidate effect (" + models::vocabulary_text() + ")\n"
      "is fitted on --data and judged on --val; nothing is looked for while validation J lies below\n"
      "the noise floor by more than its uncertainty, and the best is kept while N·ln(J_before/J_after) > p·ln(N) (BIC, N\n"
      "validation samples, p added parameters) and, after the first finding, its validation gain\n"
      "passes a signed-rank test at a family-wise 1 % over the candidates tried.\n"
      "Example:\n"
      "  panelbass diagnose --data est.csv --val val.csv --fs 3000 --sensor acceleration --out report.json \\\n"
      "      --html report.html --plots plots/ --model-out diagnosed.json\n"
      "  panelbass diagnose --data est.csv --val val.csv --fs 3000 --current-col i --out report.json\n"
      "  panelbass diagnose --data loud-est.csv --val loud-val.csv --data quiet-est.csv --val quiet-val.csv --fs 3000");
  cmd->callback([o] { run_diagnose(*o); });
}

}  // namespace panelbass::cli

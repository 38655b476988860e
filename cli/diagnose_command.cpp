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

namespace panelbass::cli {
namespace {

namespace fs = std::filesystem;

struct DiagnoseOptions {
  std::vector<std::string> data, val;  ///< one pair per drive level (--data and --val repeated, in order)
  std::string model;
  DataOptions columns;
  ReportOutputOptions outputs;
  long init = 50;
  int scan_from = 2, scan_to = 14;
  int max_findings = 4;
  long window = 300;
  models::OutputQuantity sensor = models::OutputQuantity::unknown;
  std::string current_col = "auto";  ///< the coil current when the records have one (docs/diagnosis.md: better on both families)
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

// The simulation --model names: a linear model, or a simulation that is not linear (a NARX model, a
// virtual-transducer plant JSON run without sensor noise).
struct Baseline {
  std::optional<models::LinearModel> linear;
  std::optional<models::SimulationBaseline> simulation;
  double fs() const { return linear ? linear->fs : simulation->fs; }
};

Baseline load_baseline(const std::string& path) {
  Baseline b;
  const nlohmann::json j = models::read_json_file(path);
  if (j.is_object() && j.contains("format") && j["format"].is_string() &&
      j["format"].get<std::string>().starts_with("panelbass.plant")) {
    b.simulation = models::plant_baseline(models::load_plant_file(path));
    return b;
  }
  const models::AnyModel model = models::load_model(path);
  if (const auto* linear = std::get_if<models::LinearModel>(&model.model)) {
    b.linear = *linear;
  } else {
    b.simulation = std::visit([&](const auto& m) { return models::model_baseline(model.kind(), m); }, model.model);
  }
  return b;
}

void run_diagnose(const DiagnoseOptions& o) {
  std::optional<Baseline> baseline;
  DataOptions columns = o.columns;
  if (!o.model.empty()) {
    baseline = load_baseline(o.model);
    if (!(columns.fs > 0.0)) columns.fs = baseline->fs();
  }
  if (o.data.size() != o.val.size())
    throw CLI::ValidationError("--val", "give one --val per --data (records at several levels come in pairs): " +
                                            std::to_string(o.data.size()) + " --data, " + std::to_string(o.val.size()) + " --val");
  const auto read = [&](const std::string& path) { return baseline ? columns.read_at_model_rate(path, baseline->fs()) : columns.read(path); };
  // Records at several levels: the pair with the loudest drive is diagnosed (where a nonlinear effect shows most);
  // every other pair's validation part judges each finding at its own level.
  std::vector<dsp::Record> ests, vals;
  std::size_t main = 0;
  for (std::size_t k = 0; k < o.data.size(); ++k) {
    ests.push_back(read(o.data[k]));
    vals.push_back(read(o.val[k]));
    if (!dsp::same_rate(vals[k].fs, ests[0].fs) || !dsp::same_rate(ests[k].fs, ests[0].fs))
      throw std::invalid_argument((dsp::same_rate(ests[k].fs, ests[0].fs) ? o.val[k] : o.data[k]) + ": sample rate " +
                                  std::to_string(dsp::same_rate(ests[k].fs, ests[0].fs) ? vals[k].fs : ests[k].fs) +
                                  " Hz differs from " + o.data[0] + "'s " + std::to_string(ests[0].fs) + " Hz");
    if (ests[k].columns[0].squaredNorm() / std::max<double>(1.0, static_cast<double>(ests[k].columns[0].size())) >
        ests[main].columns[0].squaredNorm() / std::max<double>(1.0, static_cast<double>(ests[main].columns[0].size())))
      main = k;
  }
  const dsp::Record& est = ests[main];
  const dsp::Record& val = vals[main];
  const std::string& data_path = o.data[main];
  const std::string& val_path = o.val[main];
  // Everything that can be refused is refused before the work starts.
  const PlotFormat format = o.outputs.prepare();
  if (!o.model_out.empty() && baseline && baseline->simulation)
    throw std::invalid_argument("--model-out: the baseline " + o.model +
                                " is not a linear model; only a linear baseline with its gray-box terms is written as a model file");

  models::DiagnosisOptions options;
  options.init = o.init;
  options.scan_from = o.scan_from;
  options.scan_to = o.scan_to;
  options.max_findings = o.max_findings;
  options.output = o.sensor;
  options.current_est = read_current(data_path, columns, est.fs, o.current_col);
  if (options.current_est.size() > 0) options.current_val = read_current(val_path, columns, val.fs, o.current_col);
  // Found by default in one record only: neither is used (a named column must be in both).
  if ((options.current_est.size() > 0) != (options.current_val.size() > 0) && o.current_col == "auto")
    options.current_est = options.current_val = Eigen::VectorXd();
  if ((options.current_est.size() > 0) != (options.current_val.size() > 0))
    throw dsp::DataError(val_path + ": has no current column while " + data_path + " has one (give --current-col none to leave it out)");
  options.level_name = val_path;
  for (std::size_t k = 0; k < vals.size(); ++k)
    if (k != main) options.other_levels.push_back({o.val[k], vals[k].columns[0], vals[k].columns[1]});
  options.progress = [](const std::string& stage) { std::cerr << "diagnose: " << stage << std::endl; };
  const models::Diagnosis d =
      baseline && baseline->simulation
          ? models::diagnose(est.columns[0], est.columns[1], val.columns[0], val.columns[1], est.fs, *baseline->simulation, options)
          : models::diagnose(est.columns[0], est.columns[1], val.columns[0], val.columns[1], est.fs,
                             baseline ? baseline->linear : std::nullopt, options);
  nlohmann::json report = models::diagnosis_to_json(d);
  report["data"] = data_path;
  report["val"] = val_path;
  if (o.data.size() > 1) {
    report["levels"] = nlohmann::json::array();
    for (std::size_t k = 0; k < o.data.size(); ++k)
      report["levels"].push_back({{"data", o.data[k]}, {"val", o.val[k]}, {"diagnosed", k == main}});
  }
  report["fs"] = est.fs;
  if (!o.model.empty()) report["model"] = o.model;
  o.outputs.name_outputs(report);
  DiagnosisPlotOptions plot_options;
  plot_options.format = format;
  plot_options.window = o.window;
  o.outputs.draw_figures(
      "panelbass-diagnose", report,
      [&](const fs::path& dir) {
        options.progress("drawing the figures");
        return plot_diagnosis(d, DiagnosisValidation{val.columns[0], val.columns[1], o.init}, dir, plot_options);
      },
      [&](const std::vector<ReportFigure>& figures) { write_diagnosis_html(o.outputs.html, report, figures, format); });
  if (!o.model_out.empty()) {
    models::write_json_file(o.model_out, models::gray_box_model_to_json(models::gray_box_model_of(d)));
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

// --sensor's names and values.
std::map<std::string, models::OutputQuantity> output_quantities() {
  std::map<std::string, models::OutputQuantity> out;
  for (auto q : models::all_output_quantities()) out[models::to_string(q)] = q;
  return out;
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
  cmd->add_option("--init", o->init, "Measured outputs that set a simulation's state before J is computed")
      ->check(CLI::Range(0L, 100000000L))
      ->capture_default_str();
  cmd->add_option("--scan-from", o->scan_from, "Without --model: lowest OE order scanned")->check(CLI::Range(1, 60))->capture_default_str();
  cmd->add_option("--scan-to", o->scan_to, "Without --model: highest OE order scanned")->check(CLI::Range(1, 60))->capture_default_str();
  cmd->add_option("--max-findings", o->max_findings, "Augmentation rounds at most")->check(CLI::Range(0, 20))->capture_default_str();
  cmd->add_option("--sensor", o->sensor,
                  "What the output measures: displacement, velocity or acceleration (a spring and a damping then act on "
                  "the displacement and its rate of change, not on the cube of one signal); unknown tries every state")
      ->transform(CLI::CheckedTransformer(output_quantities()))
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
  cmd->callback([o] {
    if (o->scan_from > o->scan_to)
      throw CLI::ValidationError("--scan-from", std::to_string(o->scan_from) + " is above --scan-to " +
                                                   std::to_string(o->scan_to));
    run_diagnose(*o);
  });
}

}  // namespace panelbass::cli

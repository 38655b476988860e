// `panelbass analyze`: the Analysis report of one model on one record (numbers from
// models::analyze_model; figures by gnuplot; an optional self-contained HTML page).

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "cli/commands.h"
#include "cli/data_options.h"
#include "cli/gnuplot.h"
#include "cli/html_report.h"
#include "cli/json_output.h"
#include "cli/progress_bar.h"
#include "cli/report_output.h"
#include "cli/report_plots.h"
#include "models/io/json_file.h"
#include "models/analysis/model_analysis.h"
#include "models/kinds/model_file.h"
#include "models/plant/plant_presets.h"

namespace panelbass::cli {
namespace {

namespace fs = std::filesystem;

struct AnalyzeOptions {
  std::string model, data, plant, history, gain_range;
  DataOptions columns;
  ReportOutputOptions outputs;
  long init = 50;
  int lags = 20;
  std::size_t segment = 0;
  long window = 600;
  int refine_iterations = 20;
  std::vector<double> frequencies{40.0, 80.0, 160.0, 320.0, 640.0};
  std::vector<double> amplitudes{0.8};
  std::size_t measure = 3000;
};

// KMIN:KMAX → the two gains.
std::pair<double, double> parse_gain_range(const std::string& text) {
  const auto colon = text.find(':');
  try {
    if (colon == std::string::npos) throw std::invalid_argument("no colon");
    std::size_t used_lo = 0, used_hi = 0;
    const double lo = std::stod(text.substr(0, colon), &used_lo);
    const double hi = std::stod(text.substr(colon + 1), &used_hi);
    if (used_lo != colon || used_hi != text.size() - colon - 1 || !(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) {
      throw std::invalid_argument("bad numbers");
    }
    return {lo, hi};
  } catch (const std::exception&) {
    throw std::invalid_argument("--gain-range expects KMIN:KMAX with KMIN < KMAX, got \"" + text + "\"");
  }
}

const nlohmann::json& meta_of(const models::AnyModel& model) {
  return std::visit([](const auto& m) -> const nlohmann::json& { return m.meta; }, model.model);
}

void run_analyze(const AnalyzeOptions& o) {
  const models::AnyModel model = models::load_model(o.model);
  const dsp::Record data = o.columns.read_at_model_rate(o.data, model.fs());
  if (o.init >= static_cast<long>(data.samples())) {
    throw std::invalid_argument("--init " + std::to_string(o.init) + " is not shorter than the data");
  }

  models::AnalysisSpec spec;
  spec.init = o.init;
  spec.max_lag = o.lags;
  spec.segment = o.segment;
  spec.refine_iterations = o.refine_iterations;
  if (!o.gain_range.empty()) std::tie(spec.gain_min, spec.gain_max) = parse_gain_range(o.gain_range);
  if (!o.plant.empty()) {
    spec.plant = models::plant_from_name_or_file(o.plant);
    spec.distortion.frequencies = o.frequencies;
    spec.distortion.amplitudes = o.amplitudes;
    spec.distortion.measure = o.measure;
  }
  std::optional<models::TrainingHistory> history;
  if (!o.history.empty()) {
    history = models::training_history_from_json(models::read_json_file(o.history), o.history);
    if (!history) throw std::invalid_argument(o.history + ": no training history (\"history\" or \"meta.history\")");
  } else {
    history = models::training_history_from_json(nlohmann::json{{"meta", meta_of(model)}}, o.model);
  }

  // Everything that can be refused is refused before the work starts.
  const PlotFormat format = o.outputs.prepare();

  ProgressBar bar("analyze");
  spec.progress = [&bar](const std::string&, double f) { bar.update(0.8 * f); };
  const models::ModelAnalysis analysis =
      models::analyze_model(model, data.columns[0], data.columns[1], spec, std::move(history));

  nlohmann::json result = models::analysis_to_json(analysis);
  result["model"] = o.model;
  result["data"] = o.data;
  result["plant"] = o.plant.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.plant);
  o.outputs.name_outputs(result);
  ReportPlotOptions plot_options;
  plot_options.format = format;
  plot_options.window = o.window;
  o.outputs.draw_figures(
      "panelbass-analyze", result,
      [&](const fs::path& dir) {
        std::vector<ReportFigure> figures = plot_analysis(analysis, dir, plot_options);
        bar.update(0.95);
        return figures;
      },
      [&](const std::vector<ReportFigure>& figures) { write_html_report(o.outputs.html, result, figures, format); });
  models::write_json_file(o.outputs.out, result);
  bar.update(1.0);
  print_result(result);
}

}  // namespace

void register_analyze(CLI::App& app) {
  auto o = std::make_shared<AnalyzeOptions>();
  CLI::App* cmd = app.add_subcommand(
      "analyze", "Analysis report of a model on data: J, residual tests, spectra, FRF, poles/zeros, root locus, distortion");
  cmd->add_option("--model", o->model, "Model file (JSON, linear or narx)")->required();
  cmd->add_option("--data", o->data, "Data, .csv or .wav")->required();
  o->columns.add_to(cmd);
  cmd->add_option("--init", o->init, "Measured outputs given to the model to set its state, then free run")
      ->check(CLI::Range(0L, 100000000L))
      ->capture_default_str();
  cmd->add_option("--plant", o->plant, "Plant preset or plant JSON file: harmonic distortion plant vs model, sensor noise floor");
  o->outputs.add_to(cmd, "Report as JSON (the object printed on stdout)", "Self-contained HTML report (figures embedded)");
  cmd->add_option("--lags", o->lags, "Lags of the residual correlation tests")->check(CLI::Range(1, 10000))->capture_default_str();
  cmd->add_option("--segment", o->segment, "Welch segment length (default: a power of 2 up to 1024, N/8)")
      ->check(CLI::Range(std::size_t{16}, std::size_t{1} << 24));
  cmd->add_option("--window", o->window, "Samples shown in the time plot")->check(CLI::Range(2L, 100000000L))->capture_default_str();
  cmd->add_option("--refine-iter", o->refine_iterations,
                  "Linear model without --history: OE iterations from the model on the data for the J figure (0 = none)")
      ->check(CLI::Range(0, 10000))
      ->capture_default_str();
  cmd->add_option("--history", o->history, "Training history: JSON with \"history\" (identify narx output) or a model file with meta.history");
  cmd->add_option("--gain-range", o->gain_range, "Root-locus gains KMIN:KMAX in raw units (default: the stable interval around 0 and a little beyond)");
  cmd->add_option("--freqs", o->frequencies, "With --plant: stepped-sine frequencies, Hz")
      ->delimiter(',')
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--amplitudes", o->amplitudes, "With --plant: drive amplitudes")
      ->delimiter(',')
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--measure", o->measure, "With --plant: samples measured per frequency")
      ->check(CLI::Range(std::size_t{100}, std::size_t{10000000}))
      ->capture_default_str();
  cmd->footer(
      "Example:\n"
      "  panelbass simulate --samples 6000 --seed 1 --out run.csv\n"
      "  panelbass identify linear --data run.csv --fs 3000 --method oe --order 8 --out lin.json\n"
      "  panelbass analyze --model lin.json --data run.csv --init 50 --plant panel-exciter \\\n"
      "      --out report.json --html report.html --plots plots/");
  cmd->callback([o] { run_analyze(*o); });
}

}  // namespace panelbass::cli

#pragma once
// The outputs of a report verb (`analyze`, `diagnose`): the JSON report (--out), a self-contained HTML
// page (--html) and the figures with their gnuplot scripts and data (--plots, --plot-format). Whatever
// can be refused is refused before the work starts; an HTML-only report draws its figures in a scratch
// directory that is removed afterwards.

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli/gnuplot.h"
#include "cli/report_plots.h"

namespace panelbass::cli {

/// Throws std::invalid_argument naming `option` and `path` unless the file could be created there: its
/// directory exists and `path` is not itself a directory.
void check_output_file(const std::string& option, const std::string& path);

/// The output options of a report verb.
struct ReportOutputOptions {
  std::string out;                  ///< --out: the JSON report (the object printed on stdout)
  std::string html;                 ///< --html: the page, empty for none
  std::string plots;                ///< --plots: the figure directory, empty for none
  std::string plot_format = "png";  ///< --plot-format

  /// Adds --out (required, described by `out_help`), --html (described by `html_help`), --plots and
  /// --plot-format to `cmd`.
  void add_to(CLI::App* cmd, const std::string& out_help, const std::string& html_help);

  /// Whether figures are wanted (--html or --plots).
  bool plotting() const { return !html.empty() || !plots.empty(); }

  /// Refuses an --out or --html that cannot be written, a --plot-format that is not png or svg, and (when
  /// figures are wanted) a missing gnuplot, naming the option or the package; creates --plots. Returns the format.
  PlotFormat prepare() const;

  /// Sets result "out", "html" (null without --html) and "plots" (null until draw_figures fills it).
  void name_outputs(nlohmann::json& result) const;

  /// Draws the figures by `draw(directory)` into --plots (or a scratch directory named after
  /// `scratch_prefix`, removed on return), sets result "plots" to their paths when --plots was given, and
  /// with --html hands them to `write_page`. Does nothing unless plotting().
  void draw_figures(const std::string& scratch_prefix, nlohmann::json& result,
                    const std::function<std::vector<ReportFigure>(const std::filesystem::path&)>& draw,
                    const std::function<void(const std::vector<ReportFigure>&)>& write_page) const;
};

}  // namespace panelbass::cli

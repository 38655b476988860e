#pragma once
// The diagnosis report as one self-contained HTML page (cli/html_report.h): the baseline, the findings
// with validation J before and after each, where the residual lies, and the figures embedded.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <vector>

#include "cli/gnuplot.h"
#include "cli/report_plots.h"

namespace panelbass::cli {

/// Writes the page for the `panelbass diagnose` report `report` (models::diagnosis_to_json plus "data",
/// "val", "fs", "model") with `figures` (images in `format`) to `path`; throws std::runtime_error naming
/// the file if an image cannot be read or the page written.
void write_diagnosis_html(const std::filesystem::path& path, const nlohmann::json& report,
                          const std::vector<ReportFigure>& figures, PlotFormat format);

}  // namespace panelbass::cli

#pragma once
// The Analysis report as one self-contained HTML page: the numbers in tables, the figures embedded as
// base64 data URIs, inline CSS, no external assets (it can be mailed or archived as one file).

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "cli/gnuplot.h"
#include "cli/report_plots.h"

namespace panelbass::cli {

/// Standard base64 (RFC 4648 §4, with '=' padding) of `bytes`.
std::string base64_encode(std::string_view bytes);

/// `text` with &, <, >, " and ' escaped for HTML.
std::string html_escaped(std::string_view text);

/// Writes the page for the `panelbass analyze` result `result` with `figures` (images in `format`) to
/// `path`; throws std::runtime_error naming the file if an image cannot be read or the page written.
void write_html_report(const std::filesystem::path& path, const nlohmann::json& result,
                       const std::vector<ReportFigure>& figures, PlotFormat format);

}  // namespace panelbass::cli

#pragma once
// Reports as self-contained HTML pages: the numbers in tables, the figures embedded as base64 data URIs,
// inline CSS, no external assets (a page can be mailed or archived as one file). The Analysis report's
// page is written here; the pieces are shared with the other reports (cli/diagnosis_report.h).

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

/// `object[key]`, or null when `object` is not an object or has no such key (a report read leniently).
const nlohmann::json& report_field(const nlohmann::json& object, const char* key);

/// A JSON value as the text of a table cell: numbers to `digits` significant digits, "–" for null,
/// yes/no for booleans, strings escaped.
std::string html_cell(const nlohmann::json& value, int digits = 4);

/// A two-column table row: <tr><th>name</th><td>value</td></tr> (`value` is HTML already).
std::string html_row(const std::string& name, const std::string& value);

/// The <figure> elements of `figures`, each image (in `format`) embedded as a base64 data URI and
/// captioned; throws std::runtime_error naming an image that cannot be read.
std::string html_figures(const std::vector<ReportFigure>& figures, PlotFormat format);

/// Writes `body` as a self-contained page titled `title` (the report style inline) to `path`; throws
/// std::runtime_error naming the file if it cannot be written.
void write_html_page(const std::filesystem::path& path, const std::string& title, const std::string& body);

/// Writes the page for the `panelbass analyze` result `result` with `figures` (images in `format`) to
/// `path`; throws std::runtime_error naming the file if an image cannot be read or the page written.
void write_html_report(const std::filesystem::path& path, const nlohmann::json& result,
                       const std::vector<ReportFigure>& figures, PlotFormat format);

}  // namespace panelbass::cli

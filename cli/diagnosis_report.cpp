#include "cli/diagnosis_report.h"

#include <sstream>
#include <string>

#include "cli/html_report.h"

namespace panelbass::cli {
namespace {

using nlohmann::json;


std::string pct(const json& v) { return v.is_null() ? html_cell(v) : html_cell(v) + " %"; }

void baseline_table(std::ostream& out, const json& baseline) {
  out << "<h2>Baseline</h2>\n<table>\n"
      << html_row("kind", html_cell(report_field(baseline, "kind"))) << html_row("source", html_cell(report_field(baseline, "source")))
      << html_row("method", html_cell(report_field(baseline, "method")))
      << html_row("orders na, nb, nk", html_cell(report_field(baseline, "na")) + ", " + html_cell(report_field(baseline, "nb")) + ", " +
                                           html_cell(report_field(baseline, "nk")))
      << html_row("J on the estimation record", pct(report_field(baseline, "J_est_pct")))
      << html_row("J on the validation record", pct(report_field(baseline, "J_val_pct")));
  if (!report_field(baseline, "order_rule").is_null()) out << html_row("how it was chosen", html_cell(report_field(baseline, "order_rule")));
  out << "</table>\n";
}

void findings_table(std::ostream& out, const json& findings) {
  out << "<h2>Findings</h2>\n";
  if (!findings.is_array() || findings.empty()) {
    out << "<p>No augmentation was significant: every candidate effect either lowered validation J too little "
           "or cost more parameters than it earned (see the rule below).</p>\n";
    return;
  }
  out << "<table class=\"findings\"><tr><th>#</th><th>effect</th><th>explanation</th><th>J before</th>"
         "<th>J after</th><th>parameters added</th><th>BIC score</th><th>how sure</th></tr>\n";
  int step = 0;
  for (const json& f : findings) {
    out << "<tr><td>" << ++step << "</td><th><code>" << html_cell(report_field(f, "effect")) << "</code></th><td class=\"text\">"
        << html_cell(report_field(f, "explanation")) << "</td><td>" << pct(report_field(f, "J_val_before_pct")) << "</td><td>"
        << pct(report_field(f, "J_val_after_pct")) << "</td><td>" << html_cell(report_field(report_field(f, "parameters"), "added")) << "</td><td>"
        << html_cell(report_field(report_field(f, "evidence"), "score_bic"), 3) << "</td><td class=\"text\">"
        << html_cell(report_field(report_field(f, "confidence"), "sentence")) << "</td></tr>\n";
  }
  out << "</table>\n";
}

// The residual against each state (before the diagnosis): how much its bin means depend on the state, its
// level at large against small values, and its change with the direction of motion.
void state_table(std::ostream& out, const json& location) {
  const json& states = report_field(location, "states");
  if (!states.is_array() || states.empty()) return;
  out << "<h3>The residual against the states (baseline, validation record)</h3>\n"
         "<table><tr><th>state</th><th>bin means over their standard error (χ²/dof; ≈ 1: none)</th>"
         "<th>rms at high |state| over low</th><th>rising − falling, in standard errors</th></tr>\n";
  for (const json& p : states) {
    out << "<tr><th>" << html_cell(report_field(p, "state")) << "</th><td>" << html_cell(report_field(p, "shape_chi2"), 3) << "</td><td>"
        << html_cell(report_field(p, "level_ratio"), 3) << "</td><td>" << html_cell(report_field(p, "direction_t"), 3) << "</td></tr>\n";
  }
  out << "</table>\n";
}

// A field of a location by its path ("frf_error.coherence"); null when absent.
const json& location_field(const json& location, const std::string& path) {
  const json* node = &location;
  std::size_t from = 0;
  while (true) {
    const std::size_t dot = path.find('.', from);
    node = &report_field(*node, path.substr(from, dot == std::string::npos ? std::string::npos : dot - from).c_str());
    if (dot == std::string::npos) return *node;
    from = dot + 1;
  }
}

void location_table(std::ostream& out, const json& location) {
  const json& before = report_field(location, "validation");
  const json& after = report_field(location, "validation_after");
  struct Row {
    const char* path;
    const char* label;
  };
  const Row rows[] = {{"residual_pct", "J (%)"},
                      {"noise_floor_pct", "noise floor: J of a model that left only noise (%; its source in noise_floor)"},
                      {"peak_frequency_hz", "largest residual PSD bin (Hz)"},
                      {"peak_over_noise", "that bin over the noise level"},
                      {"peak_threshold", "ratio pure noise exceeds with probability 0.1 %"},
                      {"frf_error.significant", "FRF error: does the input explain part of the residual"},
                      {"frf_error.frequency_hz", "FRF error: where most (Hz)"},
                      {"frf_error.band_low_hz", "FRF error: band from (Hz)"},
                      {"frf_error.band_high_hz", "FRF error: band to (Hz)"},
                      {"frf_error.relative_db", "FRF error: |H_ue / H_uy| there (dB)"},
                      {"frf_error.coherence", "FRF error: coherence of input and residual there"},
                      {"frf_error.threshold", "coherence pure noise exceeds with probability 1 %"},
                      {"distortion.periodic", "periodic input"},
                      {"distortion.period", "period (samples)"},
                      {"distortion.output_even_db", "measured output at the empty even lines over noise (dB)"},
                      {"distortion.output_odd_db", "measured output at the empty odd lines over noise (dB)"},
                      {"distortion.residual_even_db", "residual at the empty even lines over noise (dB)"},
                      {"distortion.residual_odd_db", "residual at the empty odd lines over noise (dB)"},
                      {"level_ratio", "residual rms at high |u| over that at low |u|"},
                      {"output_level_ratio", "residual rms at high |ŷ| over that at low |ŷ|"},
                      {"drift_ratio", "residual rms at the end over that at the start"},
                      {"change_time_s", "where the residual's level changes most (s)"},
                      {"change_ratio", "residual rms after it over before"},
                      {"change_t", "that change over its standard error"},
                      {"mean_t", "residual mean over its standard error"},
                      {"xcorr_lag", "lag of the largest input–residual correlation (samples)"},
                      {"xcorr_peak", "that correlation"}};
  out << "<h2>Where the residual lies (validation record)</h2>\n"
         "<table><tr><th></th><th>before (baseline)</th><th>after (final model)</th></tr>\n";
  for (const Row& r : rows) {
    out << "<tr><th>" << html_escaped(r.label) << "</th><td>" << html_cell(location_field(before, r.path)) << "</td><td>"
        << html_cell(location_field(after, r.path)) << "</td></tr>\n";
  }
  out << "</table>\n";
  state_table(out, before);
}

// The channels a diagnosis used, joined ("drive, output, current").
std::string channels_text(const json& used) {
  if (!used.is_array()) return html_cell(used);
  std::string text;
  for (const auto& c : used) text += (text.empty() ? "" : ", ") + html_cell(c);
  return text;
}

}  // namespace

void write_diagnosis_html(const std::filesystem::path& path, const json& report, const std::vector<ReportFigure>& figures,
                          PlotFormat format) {
  const std::string data = report_field(report, "data").is_string() ? report_field(report, "data").get<std::string>() : "data";
  std::ostringstream out;
  out << "<h1>panelbass diagnosis of <code>" << html_escaped(data) << "</code></h1>\n";
  out << "<h2>Result</h2>\n<table>\n"
      << html_row("estimation data", html_cell(report_field(report, "data")))
      << html_row("validation data", html_cell(report_field(report, "val")));
  if (!report_field(report, "model").is_null()) out << html_row("model diagnosed", html_cell(report_field(report, "model")));
  out << html_row("sample rate (Hz)", html_cell(report_field(report, "fs"), 8))
      << html_row("validation J before (the baseline)", pct(report_field(report, "J_val_before_pct")))
      << html_row("validation J after (final model)", pct(report_field(report, "J_val_after_pct")))
      << html_row("noise floor (J of a perfect model)", pct(report_field(report, "noise_floor_pct")))
      << html_row("channels used", channels_text(report_field(report_field(report, "channels"), "used")))
      << html_row("findings", std::to_string(report_field(report, "findings").size())) << "</table>\n";
  baseline_table(out, report_field(report, "baseline"));
  findings_table(out, report_field(report, "findings"));
  if (!report_field(report, "unexplained").is_null()) out << "<p>" << html_cell(report_field(report_field(report, "unexplained"), "sentence")) << "</p>\n";
  location_table(out, report_field(report, "location"));
  out << "<h2>Figures</h2>\n" << html_figures(figures, format);
  out << "<p><small>Written by <code>panelbass diagnose</code>. J is [2A] Σ(ŷ−y)²/Σy² in percent, from free-run "
         "simulation. Rule: "
      << html_cell(report_field(report, "rule")) << ".</small></p>\n";
  write_html_page(path, "panelbass diagnosis: " + data, out.str());
}

}  // namespace panelbass::cli

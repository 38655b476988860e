#include "cli/html_report.h"

#include <cmath>
#include <complex>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "models/io/number_text.h"

namespace panelbass::cli {
namespace {

using nlohmann::json;


std::string cell(const json& v, int digits = 4) { return html_cell(v, digits); }

void row(std::ostream& out, const std::string& name, const std::string& value) { out << html_row(name, value); }

std::string verdict(bool passes) {
  return passes ? "<span class=\"pass\">pass</span>" : "<span class=\"fail\">fail</span>";
}

void roots_table(std::ostream& out, const char* title, const json& roots, double fs) {
  out << "<h3>" << title << "</h3>\n<table><tr><th>Re z</th><th>Im z</th><th>|z|</th><th>frequency (Hz)</th></tr>\n";
  for (const json& r : roots) {
    const std::complex<double> z(r.at(0).get<double>(), r.at(1).get<double>());
    out << "<tr><td>" << cell(z.real()) << "</td><td>" << cell(z.imag()) << "</td><td>" << cell(std::abs(z))
        << "</td><td>" << cell(std::abs(std::arg(z)) * fs / (2.0 * std::numbers::pi)) << "</td></tr>\n";
  }
  out << "</table>\n";
}

std::string read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path.string() + ": cannot read the image");
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

const char* const kStyle = R"(
body { font-family: "DejaVu Sans", Helvetica, Arial, sans-serif; max-width: 1100px; margin: 2em auto; color: #202020; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; border-bottom: 1px solid #ccc; margin-top: 2em; } h3 { font-size: 1em; }
table { border-collapse: collapse; margin: 0.5em 0 1em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; font-variant-numeric: tabular-nums; }
td { white-space: nowrap; } th { background: #f3f3f3; text-align: left; } td.text { text-align: left; white-space: normal; }
.pass { color: #1a7f37; font-weight: bold; } .fail { color: #c62828; font-weight: bold; }
figure { margin: 1.5em 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #555; }
code { background: #f3f3f3; padding: 0 0.2em; }
)";

}  // namespace

// Twenty lines of RFC 4648 rather than a dependency: Debian's base64 libraries (OpenSSL's EVP_EncodeBlock,
// GLib's g_base64_encode) are not linked into panelbass, and this is all the report needs.
std::string base64_encode(std::string_view bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 3 <= bytes.size(); i += 3) {
    const unsigned v = static_cast<unsigned char>(bytes[i]) << 16 | static_cast<unsigned char>(bytes[i + 1]) << 8 |
                       static_cast<unsigned char>(bytes[i + 2]);
    for (const int shift : {18, 12, 6, 0}) out += kAlphabet[(v >> shift) & 63];
  }
  const std::size_t rest = bytes.size() - i;
  if (rest > 0) {
    unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    if (rest == 2) v |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += rest == 2 ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string html_escaped(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

const json& report_field(const json& object, const char* key) {
  static const json null_value;
  return object.is_object() && object.contains(key) ? object.at(key) : null_value;
}

std::string html_cell(const json& v, int digits) {
  if (v.is_null()) return "–";
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
  if (v.is_number()) return models::number_text(v.get<double>(), digits);
  if (v.is_string()) return html_escaped(v.get<std::string>());
  return html_escaped(v.dump());
}

std::string html_row(const std::string& name, const std::string& value) {
  return "<tr><th>" + html_escaped(name) + "</th><td>" + value + "</td></tr>\n";
}

std::string html_figures(const std::vector<ReportFigure>& figures, PlotFormat format) {
  std::string out;
  for (const ReportFigure& f : figures) {
    out += "<figure id=\"" + html_escaped(f.name) + "\"><img src=\"data:" + mime_type_of(format) + ";base64," +
           base64_encode(read_bytes(f.path)) + "\" alt=\"" + html_escaped(f.name) + "\">\n<figcaption>" +
           html_escaped(f.caption) + "</figcaption></figure>\n";
  }
  return out;
}

void write_html_page(const std::filesystem::path& path, const std::string& title, const std::string& body) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" << html_escaped(title)
       << "</title>\n<style>" << kStyle << "</style>\n</head>\n<body>\n"
       << body << "</body>\n</html>\n";
  if (!file.flush()) throw std::runtime_error(path.string() + ": cannot write the HTML report");
}

void write_html_report(const std::filesystem::path& path, const json& result, const std::vector<ReportFigure>& figures,
                       PlotFormat format) {
  std::ostringstream out;
  const std::string model = report_field(result, "model").is_string() ? report_field(result, "model").get<std::string>() : "model";
  const double fs = report_field(result, "fs").is_number() ? report_field(result, "fs").get<double>() : 0.0;
  out << "<h1>panelbass analysis of <code>" << html_escaped(model) << "</code></h1>\n";

  out << "<h2>Performance</h2>\n<table>\n";
  row(out, "model file", cell(report_field(result, "model")));
  row(out, "data file", cell(report_field(result, "data")));
  row(out, "kind", cell(report_field(result, "kind")));
  row(out, "sample rate (Hz)", cell(report_field(result, "fs"), 8));
  row(out, "samples judged (after init)", cell(report_field(result, "samples")));
  row(out, "measured outputs that set the state (init)", cell(report_field(result, "init")));
  row(out, "J, free-run simulation (%)", cell(report_field(result, "J_sim_pct")));
  row(out, "J, one-step prediction (%)", cell(report_field(result, "J_pred_pct")));
  row(out, "rms simulation error (raw units)", cell(report_field(result, "rmse")));
  row(out, "J of the output not coherent with the input (noise, distortion and spectral leakage; an upper estimate, not a floor a model cannot beat) (%)", cell(report_field(result, "J_noncoherent_pct")));
  row(out, "J of the plant's sensor noise (%)", cell(report_field(result, "J_noise_pct")));
  const json& spectrum = report_field(result, "residual_spectrum");
  row(out, "residual power over the non-coherent floor (dB)", cell(report_field(spectrum, "residual_over_noncoherent_db"), 3));
  const json& frf = report_field(result, "frf");
  row(out, "mean coherence", cell(report_field(frf, "mean_coherence"), 3));
  row(out, "rms model error where γ² ≥ 0.9 (dB)", cell(report_field(frf, "rms_error_db_where_coherent"), 3));
  out << "</table>\n";

  const json& tests = report_field(result, "residual_tests");
  out << "<h2>Residual correlation tests (Billings–Voon)</h2>\n<p>Overall: "
      << verdict(report_field(tests, "passes").is_boolean() && report_field(tests, "passes").get<bool>()) << ". "
      << cell(report_field(tests, "explanation")) << "</p>\n"
      << "<table><tr><th>test</th><th>verdict</th><th>lags outside the 95 % band</th><th>allowed</th>"
         "<th>peak |φ|</th><th>peak band</th><th>95 % band</th></tr>\n";
  if (report_field(tests, "tests").is_array()) {
    for (const json& t : report_field(tests, "tests")) {
      out << "<tr><th>" << cell(report_field(t, "name")) << "</th><td>" << verdict(report_field(t, "passes").get<bool>()) << "</td><td>"
          << cell(report_field(t, "outside")) << " of " << cell(report_field(t, "lags")) << "</td><td>" << cell(report_field(t, "allowed_outside"))
          << "</td><td>" << cell(report_field(t, "peak"), 3) << "</td><td>" << cell(report_field(t, "peak_band"), 3) << "</td><td>"
          << cell(report_field(t, "band"), 3) << "</td></tr>\n";
    }
  }
  out << "</table>\n";

  const json& locus = report_field(result, "root_locus");
  if (!locus.is_null()) {
    const json& best = report_field(locus, "best");
    const json& open = report_field(locus, "open_loop");
    out << "<h2>Poles, zeros and root locus</h2>\n<table>\n";
    row(out, "feedback", cell(report_field(locus, "feedback")));
    row(out, "gain range searched (raw units)", cell(report_field(locus, "gain_min")) + " … " + cell(report_field(locus, "gain_max")));
    row(out, "open loop: slowest pole |z|", cell(report_field(open, "max_radius"), 6));
    row(out, "open loop: impulse length to 1 % (samples)", cell(report_field(open, "impulse_length")));
    row(out, "gain with the shortest impulse response (raw units)", cell(report_field(best, "gain"), 6));
    row(out, "same gain in the model's scaled units", cell(report_field(best, "gain_scaled"), 6));
    row(out, "closed loop: slowest pole |z|", cell(report_field(best, "max_radius"), 6));
    row(out, "closed loop: impulse length to 1 % (samples)", cell(report_field(best, "impulse_length")));
    row(out, "closed loop stable", cell(report_field(best, "stable")));
    out << "</table>\n";
    roots_table(out, "Poles", report_field(result, "poles"), fs);
    roots_table(out, "Zeros", report_field(result, "zeros"), fs);
  }

  const json& history = report_field(result, "training_history");
  if (!history.is_null() && report_field(history, "points").is_array() && !report_field(history, "points").empty()) {
    const json& points = report_field(history, "points");
    out << "<h2>Training</h2>\n<table>\n";
    row(out, "source", cell(report_field(history, "source")));
    row(out, "iterations recorded", std::to_string(points.size()));
    row(out, "J at the start (%)", cell(report_field(points.front(), "J_est_pct")));
    row(out, "J at the end (%)", cell(report_field(points.back(), "J_est_pct")));
    row(out, "validation J at the end (%)", cell(report_field(points.back(), "J_val_pct")));
    out << "</table>\n";
  }

  const json& distortion = report_field(result, "distortion");
  if (!distortion.is_null()) {
    out << "<h2>Harmonic distortion, plant and model</h2>\n"
           "<table><tr><th>drive</th><th>frequency (Hz)</th><th>THD plant (%)</th><th>THD model (%)</th>"
           "<th>H2 plant (dB)</th><th>H2 model (dB)</th><th>H3 plant (dB)</th><th>H3 model (dB)</th></tr>\n";
    const json& plant = report_field(distortion, "plant");
    const json& modelled = report_field(distortion, "model");
    for (std::size_t i = 0; i < plant.size() && i < modelled.size(); ++i) {
      const json& p = plant[i];
      const json& m = modelled[i];
      const auto harmonic = [](const json& r, std::size_t h) {
        const json& list = report_field(r, "harmonic_db");
        return h < list.size() ? cell(list[h], 3) : std::string("–");
      };
      out << "<tr><td>" << cell(report_field(p, "amplitude")) << "</td><td>" << cell(report_field(p, "frequency_hz")) << "</td><td>"
          << cell(report_field(p, "thd_pct"), 3) << "</td><td>" << cell(report_field(m, "thd_pct"), 3) << "</td><td>" << harmonic(p, 0)
          << "</td><td>" << harmonic(m, 0) << "</td><td>" << harmonic(p, 1) << "</td><td>" << harmonic(m, 1)
          << "</td></tr>\n";
    }
    out << "</table>\n";
  }

  out << "<h2>Figures</h2>\n" << html_figures(figures, format);
  out << "<p><small>Written by <code>panelbass analyze</code>. J is [2A] Σ(ŷ−y)²/Σy² in percent.</small></p>\n";
  write_html_page(path, "panelbass analysis: " + model, out.str());
}

}  // namespace panelbass::cli

#include "cli/report_plots.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include "dsp/decibels.h"

namespace panelbass::cli {
namespace {

namespace fs = std::filesystem;
using models::ModelAnalysis;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
const char* const kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"};

std::string colour(std::size_t i) { return std::string("lc rgb '") + kColours[i % std::size(kColours)] + "'"; }

// `text` as a double-quoted gnuplot string (so that \n breaks lines), wrapped at about `width` characters.
std::string wrapped(const std::string& text, std::size_t width) {
  std::string out = "\"";
  std::size_t column = 0;
  std::istringstream words(text);
  std::string word;
  while (words >> word) {
    if (column > 0 && column + 1 + word.size() > width) {
      out += "\\n";
      column = 0;
    } else if (column > 0) {
      out += ' ';
      ++column;
    }
    for (const char c : word) {
      if (c == '"' || c == '\\') out += '\\';
      out += c;
    }
    column += word.size();
  }
  return out + "\"";
}

fs::path plot_time(const ModelAnalysis& a, const fs::path& dir, const ReportPlotOptions& o) {
  const Eigen::Index n = std::min<Eigen::Index>(std::max<Eigen::Index>(o.window, 2), a.samples);
  Eigen::VectorXd t(n);
  for (Eigen::Index k = 0; k < n; ++k) t[k] = static_cast<double>(a.init + k) / a.fs;
  const Eigen::VectorXd y = a.y.head(n), y_sim = a.y_sim.head(n);
  const Eigen::VectorXd e = y - y_sim;
  GnuplotFigure f("time");
  f.add_block({t, y, y_sim, e});
  f << "set title " + gnuplot_quoted("Measured and simulated output (free run after " + std::to_string(a.init) +
                                      " measured outputs): J = " + gnuplot_number(a.j_sim_pct) + " %")
    << "set xlabel 'time (s)'"
    << "set ylabel 'output (raw units)'"
    << "set key top right box opaque"
    << "plot " + f.data() + " index 0 using 1:2 with lines lw 1.6 lc rgb '#202020' title 'measured y', \\\n"
       "     '' index 0 using 1:3 with lines lw 1.2 lc rgb '#d62728' title 'simulated ŷ', \\\n"
       "     '' index 0 using 1:4 with lines lw 1 lc rgb '#1f77b4' title 'residual y − ŷ'";
  return f.render(dir, o.format);
}

fs::path plot_psd(const ModelAnalysis& a, const fs::path& dir, const ReportPlotOptions& o) {
  const models::ResidualSpectrum& s = a.spectrum;
  const Eigen::Index n = s.frequency.size() - 1;  // DC left out: the means were removed
  GnuplotFigure f("psd");
  f.add_block({s.frequency.tail(n), dsp::power_db(s.output_psd.tail(n)), dsp::power_db(s.residual_psd.tail(n)),
               dsp::power_db(s.noncoherent_psd.tail(n))});
  f << "set title " + gnuplot_quoted("Spectra of output and residual against the noise floor (Welch, " +
                                      std::to_string(s.segment) + "-point segments)")
    << "set xlabel 'frequency (Hz)'"
    << "set ylabel 'PSD (dB re 1 unit²/Hz)'"
    << "set xrange [0:" + gnuplot_number(a.fs / 2.0, 8) + "]"
    << "set key top right box opaque";
  std::string plot = "plot " + f.data() +
                     " index 0 using 1:2 with lines lw 1.5 lc rgb '#202020' title 'output y', \\\n"
                     "     '' index 0 using 1:3 with lines lw 1.5 lc rgb '#d62728' title 'residual y − ŷ (J = " +
                     gnuplot_number(a.j_sim_pct) + " %)', \\\n"
                     "     '' index 0 using 1:4 with lines lw 1.2 dt 2 lc rgb '#1f77b4' title 'non-coherent output (1−γ²)·S_{yy}, upper estimate (J = " +
                     gnuplot_number(a.j_noncoherent_pct) + " %)'";
  if (std::isfinite(s.sensor_noise_psd) && s.sensor_noise_psd > 0.0) {
    plot += ", \\\n     " + gnuplot_number(10.0 * std::log10(s.sensor_noise_psd), 8) +
            " with lines lw 1.2 dt 3 lc rgb '#2ca02c' title 'plant sensor noise (J = " + gnuplot_number(a.j_noise_pct) + " %)'";
  }
  f << plot;
  return f.render(dir, o.format);
}

fs::path plot_frf(const ModelAnalysis& a, const fs::path& dir, const ReportPlotOptions& o) {
  const models::FrfComparison& r = a.frf;
  const Eigen::Index n = r.frequency.size() - 1;
  GnuplotFigure f("frf");
  f.add_block({r.frequency.tail(n), dsp::magnitude_db(r.measured.tail(n)), dsp::magnitude_db(r.model.tail(n)), r.coherence.tail(n)});
  f << "set title 'Frequency response: measured (H1) and model, with the coherence of the data'"
    << "set xlabel 'frequency (Hz)'"
    << "set ylabel 'magnitude (dB re 1 output unit per input unit)'"
    << "set y2label 'coherence γ²'"
    << "set logscale x"
    << "set xrange [" + gnuplot_number(r.frequency[1], 8) + ":" + gnuplot_number(a.fs / 2.0, 8) + "]"
    << "set y2range [0:1.05]"
    << "set ytics nomirror"
    << "set y2tics 0.2"
    << "set key bottom left box opaque"
    << "plot " + f.data() + " index 0 using 1:2 with lines lw 1.6 lc rgb '#202020' title 'measured H1', \\\n"
       "     '' index 0 using 1:3 with lines lw 1.4 lc rgb '#d62728' title " +
           gnuplot_quoted("model (" + r.model_source + ")") + ", \\\n"
       "     '' index 0 using 1:4 axes x1y2 with lines lw 1 lc rgb '#2ca02c' title 'coherence γ² (right axis)'";
  return f.render(dir, o.format);
}

fs::path plot_residual_tests(const ModelAnalysis& a, const fs::path& dir, const ReportPlotOptions& o) {
  const models::ResidualTests& r = a.residual_tests;
  struct Panel {
    const models::CorrelationTest* test;
    const char* label;  // enhanced-text name
  };
  const Panel panels[] = {{&r.ee, "φ_{εε}(τ)"},
                          {&r.ue, "φ_{uε}(τ)"},
                          {&r.u2e, "φ_{u^2'ε}(τ)"},
                          {&r.u2e2, "φ_{u^2'ε^2'}(τ)"},
                          {&r.e_eu, "φ_{ε(εu)}(τ)"}};
  GnuplotFigure f("residual_tests", 1000, 900);
  for (const Panel& p : panels) {
    Eigen::VectorXd lags(static_cast<Eigen::Index>(p.test->lags.size()));
    for (Eigen::Index k = 0; k < lags.size(); ++k) lags[k] = p.test->lags[static_cast<std::size_t>(k)];
    f.add_block({lags, p.test->values});
  }
  f << "set multiplot layout 3,2 title " +
           gnuplot_quoted(std::string("Residual correlation tests (Billings–Voon), N = ") + std::to_string(a.samples) +
                          ": " + (r.passes ? "all pass" : "some fail")) +
           " font ',12'"
    << "set xlabel 'lag τ (samples)'"
    << "set ylabel 'normalised correlation'"
    << "set key top right font ',8' box opaque";
  for (std::size_t i = 0; i < std::size(panels); ++i) {
    const models::CorrelationTest& t = *panels[i].test;
    const double top = 1.3 * std::max({t.peak, t.peak_band, t.band});
    f << "set title " + gnuplot_quoted(std::string(panels[i].label) + ": " + (t.passes ? "pass" : "FAIL") + " (" +
                                      std::to_string(t.outside) + " of " + std::to_string(t.lags.size()) +
                                      " lags outside, " + std::to_string(t.allowed_outside) + " allowed; peak " +
                                      gnuplot_number(t.peak, 2) + ")")
      << "set xrange [" + std::to_string(t.lags.front()) + "-0.5:" + std::to_string(t.lags.back()) + "+0.5]"
      << "set yrange [" + gnuplot_number(-top, 6) + ":" + gnuplot_number(top, 6) + "]"
      << "plot " + f.data() + " index " + std::to_string(i) + " using 1:2 with impulses lw 3 " +
             (t.passes ? colour(0) : colour(1)) + " title 'φ', \\\n"
             "     " + gnuplot_number(t.band, 6) + " with lines dt 2 lc rgb '#555555' title '95 % band ±1.96/√N', \\\n"
             "     " + gnuplot_number(-t.band, 6) + " with lines dt 2 lc rgb '#555555' notitle, \\\n"
             "     " + gnuplot_number(t.peak_band, 6) + " with lines dt 3 lc rgb '#ff7f0e' title 'peak band', \\\n"
             "     " + gnuplot_number(-t.peak_band, 6) + " with lines dt 3 lc rgb '#ff7f0e' notitle";
  }
  f << "unset title"
    << "unset key"
    << "unset border"
    << "unset tics"
    << "unset grid"
    << "unset xlabel"
    << "unset ylabel"
    << "set xrange [0:1]"
    << "set yrange [0:1]"
    << "set label 1 " + wrapped(r.explanation, 48) + " at 0.02,0.6 left noenhanced font ',10'"
    << "plot NaN notitle"
    << "unset multiplot";
  return f.render(dir, o.format);
}

fs::path plot_pole_zero(const ModelAnalysis& a, const fs::path& dir, const ReportPlotOptions& o) {
  const models::PoleZeroAnalysis& pz = *a.pole_zero;
  GnuplotFigure f("poles_zeros", 760, 720);
  Eigen::VectorXd cx(361), cy(361);
  for (int k = 0; k <= 360; ++k) {
    cx[k] = std::cos(k * M_PI / 180.0);
    cy[k] = std::sin(k * M_PI / 180.0);
  }
  f.add_block({cx, cy});
  std::vector<double> re, im, gain;
  for (const models::ClosedLoop& loop : pz.locus) {
    for (Eigen::Index k = 0; k < loop.poles.size(); ++k) {
      re.push_back(loop.poles[k].real());
      im.push_back(loop.poles[k].imag());
      gain.push_back(loop.gain);
    }
  }
  const auto vec = [](const std::vector<double>& v) { return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()))); };
  const auto block_of = [&](const Eigen::VectorXcd& roots) {
    if (roots.size() == 0) return f.add_block({Eigen::VectorXd::Constant(1, kNaN), Eigen::VectorXd::Constant(1, kNaN)});
    return f.add_block({roots.real(), roots.imag()});
  };
  if (re.empty()) {
    re.push_back(kNaN);
    im.push_back(kNaN);
    gain.push_back(0.0);
  }
  f.add_block({vec(re), vec(im), vec(gain)});
  block_of(pz.poles);
  block_of(pz.zeros);
  block_of(pz.best.poles);
  const std::string length = std::isfinite(pz.best.impulse_length) ? gnuplot_number(pz.best.impulse_length) + " samples" : "unbounded";
  const std::string open = std::isfinite(pz.open_loop.impulse_length) ? gnuplot_number(pz.open_loop.impulse_length) : "∞";
  f << "set title " + gnuplot_quoted("Poles, zeros and root locus of u = r − k·y: shortest impulse at k = " +
                                      gnuplot_number(pz.best.gain, 4) + " (" + length + ", open loop " + open + ")")
    << "set size ratio -1"
    << "set xrange [-1.6:1.6]"
    << "set yrange [-1.6:1.6]"
    << "set xlabel 'Re z'"
    << "set ylabel 'Im z'"
    << "set cblabel 'feedback gain k (raw units)'"
    << "set palette defined (0 '#3b4cc0', 0.5 '#aaaaaa', 1 '#b40426')"
    << "set cbrange [" + gnuplot_number(pz.gain_min, 8) + ":" + gnuplot_number(pz.gain_max, 8) + "]"
    << "set key bottom left box opaque font ',9'"
    << "plot " + f.data() + " index 0 using 1:2 with lines lw 1 lc rgb '#555555' title 'unit circle', \\\n"
       "     '' index 1 using 1:2:3 with points pt 7 ps 0.35 lc palette title 'closed-loop poles (root locus)', \\\n"
       "     '' index 2 using 1:2 with points pt 2 ps 2 lw 2 lc rgb '#202020' title 'poles (k = 0)', \\\n"
       "     '' index 3 using 1:2 with points pt 6 ps 2 lw 2 lc rgb '#1f77b4' title 'zeros', \\\n"
       "     '' index 4 using 1:2 with points pt 9 ps 1.8 lc rgb '#2ca02c' title " +
           gnuplot_quoted("poles at k = " + gnuplot_number(pz.best.gain, 4));
  return f.render(dir, o.format);
}

fs::path plot_history(const ModelAnalysis& a, const fs::path& dir, const ReportPlotOptions& o) {
  const models::TrainingHistory& h = *a.history;
  const auto n = static_cast<Eigen::Index>(h.points.size());
  Eigen::VectorXd x(n), j_est(n), j_val(n);
  bool positive = true, has_val = false;
  for (Eigen::Index k = 0; k < n; ++k) {
    const models::HistoryPoint& p = h.points[static_cast<std::size_t>(k)];
    x[k] = static_cast<double>(k);
    j_est[k] = p.j_est_pct;
    j_val[k] = p.j_val_pct;
    has_val = has_val || std::isfinite(p.j_val_pct);
    if ((std::isfinite(p.j_est_pct) && p.j_est_pct <= 0.0) || (std::isfinite(p.j_val_pct) && p.j_val_pct <= 0.0)) {
      positive = false;
    }
  }
  GnuplotFigure f("training");
  f.add_block({x, j_est, j_val});
  f << "set title " + gnuplot_quoted("J per iteration: " + h.source) + " noenhanced"
    << "set xlabel 'iteration (all stages in order)'"
    << "set ylabel 'J (%), simulation'"
    << "set xrange [0:" + std::to_string(std::max<Eigen::Index>(n - 1, 1)) + "]"
    << "set xtics " + std::to_string(std::max<Eigen::Index>(1, (n + 9) / 10))
    << "set key top right box opaque";
  if (positive) f << "set logscale y";
  // A dotted line where the training mode changes (pem → oem-d, …).
  for (std::size_t k = 0, mark = 1; k < h.points.size(); ++k) {
    if (k == 0 ? h.points.back().mode != h.points.front().mode : h.points[k].mode != h.points[k - 1].mode) {
      const std::string id = std::to_string(mark++), at = std::to_string(k);
      f << "set arrow " + id + " from " + at + ", graph 0 to " + at + ", graph 1 nohead dt 3 lc rgb '#888888'"
        << "set label " + id + " " + gnuplot_quoted(h.points[k].mode) + " at " + at + ", graph 0.95 offset 0.5,0 noenhanced";
    }
  }
  std::string plot = "plot " + f.data() + " index 0 using 1:2 with linespoints pt 7 ps 0.6 lw 1.5 " + colour(0) +
                     " title 'J on the estimation data'";
  if (has_val) plot += ", \\\n     '' index 0 using 1:3 with linespoints pt 5 ps 0.6 lw 1.5 " + colour(1) + " title 'J on the validation data'";
  f << plot;
  return f.render(dir, o.format);
}

fs::path plot_harmonics(const ModelAnalysis& a, std::size_t amplitude_index, const fs::path& dir,
                        const ReportPlotOptions& o) {
  const models::DistortionComparison& d = *a.distortion;
  const double amplitude = a.distortion_amplitudes.at(amplitude_index);
  std::vector<std::size_t> rows;
  for (std::size_t i = 0; i < d.plant.size(); ++i) {
    if (d.plant[i].amplitude == amplitude) rows.push_back(i);
  }
  const std::size_t orders = rows.empty() ? 0 : d.plant[rows.front()].harmonic_db.size();
  GnuplotFigure f("harmonics-" + std::to_string(amplitude_index + 1));
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (std::size_t h = 0; h < orders; ++h) {
    Eigen::VectorXd freq(static_cast<Eigen::Index>(rows.size())), plant(freq.size()), model(freq.size());
    for (std::size_t r = 0; r < rows.size(); ++r) {
      const auto k = static_cast<Eigen::Index>(r);
      freq[k] = d.plant[rows[r]].frequency;
      plant[k] = d.plant[rows[r]].harmonic_db[h];
      model[k] = d.model[rows[r]].harmonic_db[h];
      for (const double v : {plant[k], model[k]}) {
        if (std::isfinite(v)) {
          low = std::min(low, v);
          high = std::max(high, v);
        }
      }
    }
    f.add_block({freq, plant, model});
  }
  // A linear model makes no harmonics (−300 dB of rounding): keep the axis where the plant's are.
  double plant_low = std::numeric_limits<double>::infinity();
  for (const std::size_t r : rows) {
    for (const double v : d.plant[r].harmonic_db) {
      if (std::isfinite(v)) plant_low = std::min(plant_low, v);
    }
  }
  if (std::isfinite(plant_low)) low = std::max(low, plant_low - 40.0);
  if (!std::isfinite(low) || !std::isfinite(high)) {
    low = -120.0;
    high = 0.0;
  }
  const double axis_low = std::floor(low / 10.0) * 10.0 - 5.0;
  bool model_visible = false;
  for (const std::size_t r : rows) {
    for (const double v : d.model[r].harmonic_db) model_visible = model_visible || (std::isfinite(v) && v >= axis_low);
  }
  f << "set title " + gnuplot_quoted("Harmonic distortion at drive " + gnuplot_number(amplitude) +
                                      ": plant (solid) and model (dashed), stepped sine" +
                                      (model_visible ? "" : "; the model's lie below the axis"))
    << "set xlabel 'fundamental frequency (Hz)'"
    << "set ylabel 'harmonic level (dB re fundamental)'"
    << "set logscale x"
    << "set yrange [" + gnuplot_number(axis_low, 8) + ":" + gnuplot_number(std::ceil(high / 10.0) * 10.0 + 5.0, 8) + "]"
    << "set key outside right top box";
  std::string plot = "plot ";
  for (std::size_t h = 0; h < orders; ++h) {
    const std::string order = "H" + std::to_string(h + 2);
    if (h > 0) plot += ", \\\n     ";
    plot += f.data() + " index " + std::to_string(h) + " using 1:2 with linespoints pt 7 lw 1.6 " + colour(h) +
            " title '" + order + " plant', \\\n     '' index " + std::to_string(h) +
            " using 1:3 with linespoints pt 6 dt 2 lw 1.4 " + colour(h) + " title '" + order + " model'";
  }
  if (orders == 0) plot += "NaN notitle";
  f << plot;
  return f.render(dir, o.format);
}

}  // namespace

std::vector<ReportFigure> plot_analysis(const ModelAnalysis& a, const fs::path& dir, const ReportPlotOptions& options) {
  const fs::path where = fs::absolute(dir);
  std::vector<ReportFigure> figures;
  figures.push_back({"time", "Measured output and the model's free-run simulation, with the residual, over the first " +
                                 std::to_string(std::min<Eigen::Index>(options.window, a.samples)) + " judged samples.",
                     plot_time(a, where, options)});
  figures.push_back({"psd",
                     "Power spectra of the output and of the residual; the dashed floor is the output not coherent with "
                     "the input (noise and nonlinear distortion), which no linear model can explain.",
                     plot_psd(a, where, options)});
  figures.push_back({"frf", "Measured frequency response (H1, Welch) against the model's, with the coherence of the data.",
                     plot_frf(a, where, options)});
  figures.push_back({"residual_tests",
                     "Billings–Voon correlation tests of the residual: bars outside the dashed 95 % band point to "
                     "dynamics (φ_uε), even-order (φ_u²ε) or odd-order (φ_u²ε²) nonlinearity the model leaves out.",
                     plot_residual_tests(a, where, options)});
  if (a.pole_zero) {
    figures.push_back({"poles_zeros",
                       "Poles (×) and zeros (○) of the model on the unit circle, the root locus of constant output "
                       "feedback coloured by gain, and the poles at the gain with the shortest impulse response.",
                       plot_pole_zero(a, where, options)});
  }
  if (a.history && !a.history->points.empty()) {
    figures.push_back({"training", "J per iteration (" + a.history->source + ").", plot_history(a, where, options)});
  }
  if (a.distortion) {
    for (std::size_t i = 0; i < a.distortion_amplitudes.size(); ++i) {
      figures.push_back({"harmonics-" + std::to_string(i + 1),
                         "Harmonic levels against frequency at drive " + gnuplot_number(a.distortion_amplitudes[i]) +
                             ", plant and model, by stepped sine.",
                         plot_harmonics(a, i, where, options)});
    }
  }
  return figures;
}

}  // namespace panelbass::cli

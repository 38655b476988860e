#include "cli/diagnosis_plots.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

#include "dsp/decibels.h"
#include "dsp/spectrum.h"
#include "models/diagnosis/diagnosis_locate.h"
#include "models/diagnosis/diagnosis_terms.h"

namespace panelbass::cli {
namespace {

namespace fs = std::filesystem;
using models::Diagnosis;

// The validation record's two simulations, from the first judged sample on.
struct JudgedSimulations {
  Eigen::VectorXd y;         ///< measured
  Eigen::VectorXd baseline;  ///< the linear model diagnosed
  Eigen::VectorXd final;     ///< the augmented model the diagnosis ends with
  Eigen::VectorXd final_full;  ///< the augmented model's simulation of the whole record (its states need the start)
};


fs::path plot_residual_spectrum(const Diagnosis& d, const JudgedSimulations& s, double fs, const fs::path& dir,
                                const DiagnosisPlotOptions& o) {
  const dsp::WelchSpec spec{dsp::residual_welch_segment(s.y.size()), 0.5, dsp::Window::hann};
  const dsp::PowerSpectrum before = dsp::welch_psd(s.y - s.baseline, fs, spec);
  const dsp::PowerSpectrum after = dsp::welch_psd(s.y - s.final, fs, spec);
  const Eigen::Index n = before.frequency.size() - 1;  // DC left out
  GnuplotFigure f("residual_spectrum");
  f.add_block({before.frequency.tail(n), dsp::power_db(before.psd.tail(n)), dsp::power_db(after.psd.tail(n))});
  f << "set title " + gnuplot_quoted("Residual spectrum on the validation record (Welch, " + std::to_string(spec.segment) +
                                      "-point segments): before and after the diagnosis")
    << "set xlabel 'frequency (Hz)'"
    << "set ylabel 'PSD of y − ŷ (dB re 1 unit²/Hz)'"
    << "set xrange [0:" + gnuplot_number(fs / 2.0, 8) + "]"
    << "set key top right box opaque";
  std::string plot = "plot " + f.data() +
                     " index 0 using 1:2 with lines lw 1.5 lc rgb '#d62728' title 'before: " + d.baseline_kind + " baseline (J = " +
                     gnuplot_number(d.j_val_before_pct) + " %)', \\\n"
                     "     '' index 0 using 1:3 with lines lw 1.5 lc rgb '#1f77b4' title 'after: augmented model (J = " +
                     gnuplot_number(d.j_val_after_pct) + " %)'";
  if (std::isfinite(d.located_val.noise_psd) && d.located_val.noise_psd > 0.0) {
    plot += ", \\\n     " + gnuplot_number(10.0 * std::log10(d.located_val.noise_psd), 8) +
            " with lines lw 1.2 dt 2 lc rgb '#2ca02c' title 'noise floor (J = " + gnuplot_number(d.noise_floor_pct) + " %)'";
  }
  f << plot;
  return f.render(dir, o.format);
}

fs::path plot_fit(const Diagnosis& d, const JudgedSimulations& s, double fs, Eigen::Index init, const fs::path& dir,
                  const DiagnosisPlotOptions& o) {
  const Eigen::Index n = std::min<Eigen::Index>(std::max<Eigen::Index>(o.window, 2), s.y.size());
  const Eigen::VectorXd t = (Eigen::VectorXd::LinSpaced(n, 0.0, static_cast<double>(n - 1)).array() + init) / fs;
  GnuplotFigure f("fit");
  f.add_block({t, s.y.head(n), s.baseline.head(n), s.final.head(n)});
  f << "set title " + gnuplot_quoted("Validation record: measured and simulated (free run after " + std::to_string(init) +
                                      " measured outputs)")
    << "set xlabel 'time (s)'"
    << "set ylabel 'output (raw units)'"
    << "set key top right box opaque"
    << "plot " + f.data() + " index 0 using 1:2 with lines lw 1.8 lc rgb '#202020' title 'measured y', \\\n"
       "     '' index 0 using 1:3 with lines lw 1 dt 2 lc rgb '#d62728' title '" + d.baseline_kind + " baseline (J = " +
           gnuplot_number(d.j_val_before_pct) + " %)', \\\n"
       "     '' index 0 using 1:4 with lines lw 1.3 lc rgb '#1f77b4' title 'augmented model (J = " +
           gnuplot_number(d.j_val_after_pct) + " %)'";
  return f.render(dir, o.format);
}

fs::path plot_j_per_step(const Diagnosis& d, const fs::path& dir, const DiagnosisPlotOptions& o) {
  const auto steps = static_cast<Eigen::Index>(d.findings.size()) + 1;
  Eigen::VectorXd x(steps), j(steps);
  std::string tics = "set xtics (\"baseline\" 0";
  x[0] = 0.0;
  j[0] = d.baseline_j_val_pct;
  for (Eigen::Index k = 1; k < steps; ++k) {
    const models::Finding& finding = d.findings[static_cast<std::size_t>(k - 1)];
    x[k] = static_cast<double>(k);
    j[k] = finding.j_val_after_pct;
    tics += ", " + gnuplot_quoted("+ " + models::to_string(finding.effect)) + " " + std::to_string(k);
  }
  GnuplotFigure f("j_per_step", 900, 480);
  f.add_block({x, j});
  const double top = std::max(j.maxCoeff(), d.noise_floor_pct);
  f << "set title 'Validation J after each step of the diagnosis'"
    << tics + ") noenhanced"
    << "set xrange [-0.6:" + gnuplot_number(static_cast<double>(steps) - 0.4, 6) + "]"
    << "set yrange [0:" + gnuplot_number(1.15 * std::max(top, 1e-12), 8) + "]"
    << "set ylabel 'J on the validation record (%)'"
    << "set style fill solid 0.6 border rgb '#1f77b4'"
    << "set boxwidth 0.6"
    << "set key top right box opaque"
    << "plot " + f.data() + " index 0 using 1:2 with boxes lc rgb '#1f77b4' title 'J (%)', \\\n"
       "     '' index 0 using 1:2:(sprintf('%.3g %%', $2)) with labels offset 0,0.8 notitle, \\\n"
       "     " + gnuplot_number(d.noise_floor_pct, 8) + " with lines lw 1.2 dt 2 lc rgb '#2ca02c' title 'noise floor (J = " +
           gnuplot_number(d.noise_floor_pct) + " %)'";
  return f.render(dir, o.format);
}

// The residual's mean in bins of each state (models::StateProfile), before the diagnosis (solid) and after
// it (dashed): a missing nonlinearity shows as a curve, a residual that ignores the state as a flat line.
fs::path plot_residual_against_states(const Diagnosis& d, const fs::path& dir, const DiagnosisPlotOptions& o) {
  static const char* const kColours[] = {"#9467bd", "#d62728", "#1f77b4", "#2ca02c"};
  GnuplotFigure f("residual_vs_state", 900, 560);
  std::string plot = "plot ";
  const auto add = [&](const models::StateProfile& p, std::size_t colour, bool after) {
    const int block = f.add_block({p.centre, p.mean});
    if (plot.size() > 5) plot += ", \\\n     ";
    plot += (plot.size() > 5 ? "''" : f.data()) + " index " + std::to_string(block) + " using 1:2 with linespoints lw " +
            (after ? "1 dt 2" : "1.6") + " pt 7 ps 0.6 lc rgb '" + kColours[colour % 4] + "' title " +
            gnuplot_quoted(p.state + (after ? " (after)" : " (before)"));
  };
  for (std::size_t i = 0; i < d.located_val.states.size(); ++i) add(d.located_val.states[i], i, false);
  for (std::size_t i = 0; i < d.located_val_after.states.size(); ++i) add(d.located_val_after.states[i], i, true);
  f << "set title 'Validation residual against each state: its mean in 12 equal-count bins' noenhanced"
    << "set xlabel 'state (units of its rms about its mean)'"
    << "set ylabel 'mean of y − ŷ in the bin (raw output units)'"
    << "set key outside right box opaque noenhanced"
    << plot + ", \\\n     0 with lines lw 1 lc rgb '#555555' notitle";
  return f.render(dir, o.format);
}

// The term's static contribution Σⱼ gⱼ·Σcⱼ (raw output units) against its state z, thinned to at most
// o.scatter_points points; nothing when the term has no static feature or the feature does not vary.
std::optional<fs::path> plot_term(const Diagnosis& d, std::size_t index, const models::StateSignals& states,
                                  Eigen::Index init, const fs::path& dir, const DiagnosisPlotOptions& o) {
  const models::DiagnosisTerm& term = d.model.terms[index];
  Eigen::MatrixXd features;
  try {
    features = models::term_features(term, states);
  } catch (const std::invalid_argument&) {
    return std::nullopt;  // an effect that acts through the dynamics, not through a static function of a state
  }
  const Eigen::VectorXd& z = states.of(term.proxy);
  const Eigen::Index n = z.size() - init;
  // The coefficients come in one block of lags + kTermLead per feature of the term (models::term_regressors):
  // a block's sum is its feature's gain at low frequency, and the term's static contribution their sum.
  const Eigen::Index block = d.model.lags + models::kTermLead;
  if (n < 2 || features.rows() != z.size() || term.coefficients.size() != block * features.cols()) return std::nullopt;
  Eigen::VectorXd feature = Eigen::VectorXd::Zero(z.size());
  for (Eigen::Index j = 0; j < features.cols(); ++j)
    feature += features.col(j) * term.coefficients.segment(j * block, block).sum();
  if (!(feature.tail(n).maxCoeff() > feature.tail(n).minCoeff())) return std::nullopt;  // a constant is not a function of a state
  const double gain = d.model.linear.scaling.y_scale;
  const Eigen::Index stride = std::max<Eigen::Index>(1, (n + o.scatter_points - 1) / std::max<Eigen::Index>(o.scatter_points, 1));
  const Eigen::Index points = (n + stride - 1) / stride;
  Eigen::VectorXd x(points), y(points);
  for (Eigen::Index k = 0; k < points; ++k) {
    x[k] = z[init + k * stride];
    y[k] = feature[init + k * stride] * gain;
  }
  const std::string effect = models::to_string(term.effect), proxy = models::to_string(term.proxy);
  GnuplotFigure f("term-" + std::to_string(index + 1), 760, 560);
  f.add_block({x, y});
  f << "set title " + gnuplot_quoted(effect + " acting on the " + proxy + " state: the term's static features times their "
                                     "summed coefficients") + " noenhanced"
    << "set xlabel " + gnuplot_quoted(proxy + " state z (zero mean, unit rms on the estimation record)") + " noenhanced"
    << "set ylabel 'Σ g_j(z)·Σc_j (raw output units)'"
    << "set key top left box opaque"
    << "plot " + f.data() + " index 0 using 1:2 with points pt 7 ps 0.3 lc rgb '#1f77b4' title " +
           gnuplot_quoted(std::to_string(points) + " validation samples") + ", \\\n"
       "     0 with lines lw 1 lc rgb '#555555' notitle";
  return f.render(dir, o.format);
}

}  // namespace

std::vector<ReportFigure> plot_diagnosis(const Diagnosis& d, const DiagnosisValidation& validation, const fs::path& dir,
                                         const DiagnosisPlotOptions& options) {
  const models::LinearModel& linear = d.model.linear;
  const double fs = linear.fs;
  const Eigen::Index init = validation.init;
  if (validation.u.size() != validation.y.size() || validation.u.size() < init + 256)
    throw std::invalid_argument("diagnosis plots: the validation record has " + std::to_string(validation.u.size()) +
                                " inputs and " + std::to_string(validation.y.size()) + " outputs; at least " +
                                std::to_string(init + 256) + " of each needed");
  const Eigen::Index n = validation.u.size() - init;
  JudgedSimulations s;
  s.final_full = models::simulate_augmented(d.model, validation.u, validation.y, init);
  s.y = validation.y.tail(n);
  s.baseline = models::simulate_augmented(d.baseline_model, validation.u, validation.y, init).tail(n);
  s.final = s.final_full.tail(n);

  const fs::path where = fs::absolute(dir);
  std::vector<ReportFigure> figures;
  figures.push_back({"residual_spectrum",
                     "Power spectrum of the validation residual y − ŷ of the baseline and of the final augmented "
                     "model; the dashed line is the residual's white-noise level, which no model can go below.",
                     plot_residual_spectrum(d, s, fs, where, options)});
  figures.push_back({"fit", "Measured validation output against the baseline's and the final model's free-run simulation, "
                            "over the first " + std::to_string(std::min<Eigen::Index>(options.window, n)) +
                                " judged samples.",
                     plot_fit(d, s, fs, init, where, options)});
  figures.push_back({"j_per_step", "Validation J of the baseline and after each finding, against the noise floor.",
                     plot_j_per_step(d, where, options)});

  if (!d.located_val.states.empty()) {
    figures.push_back({"residual_vs_state",
                       "The validation residual's mean in bins of the input, the simulated output and its leaky single "
                       "and double integral (velocity and displacement for an accelerometer), before the diagnosis "
                       "(solid) and after it (dashed): a physics left out that depends on a state bends its curve.",
                       plot_residual_against_states(d, where, options)});
  }

  models::StateSignals reference;
  reference.mean = d.model.state_mean;
  reference.rms = d.model.state_rms;
  const models::StateSignals states =
      models::state_signals(linear.scaling.scale_u(validation.u), linear.scaling.scale_y(s.final_full), fs, &reference);
  for (std::size_t i = 0; i < d.model.terms.size(); ++i) {
    if (const std::optional<fs::path> image = plot_term(d, i, states, init, where, options)) {
      const models::DiagnosisTerm& term = d.model.terms[i];
      figures.push_back({"term-" + std::to_string(i + 1),
                         models::to_string(term.effect) + ": the term's static feature g times its summed coefficients "
                         "against the " + models::to_string(term.proxy) +
                             " state it acts on, on the final model's simulation of the validation record.",
                         *image});
    }
  }
  return figures;
}

}  // namespace panelbass::cli

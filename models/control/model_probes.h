#pragma once
// The distortion probes of a chain's evaluation, run on the design's plant model (NARX or ss) instead of the
// transducer (model mode): the probe sine, its amplitude rule, and the THD the model shows with and
// without the neural feedback. `evaluate` reports these beside the transducer's figures; `design nn` can
// keep the restart whose worst probe the controller cuts most on its own model.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "dsp/biquad.h"
#include "models/control/lq_feedforward.h"
#include "models/control/neural_feedback.h"
#include "models/linear/state_space.h"

namespace panelbass::models {

/// How long a probe sine runs: it fades in (raised cosine) over fade_seconds, and of its settle_seconds +
/// analysis_seconds the last analysis_seconds are analysed (whole periods for integer-Hz probes).
struct ProbeTiming {
  double fade_seconds = 0.2;      ///< fade-in
  double settle_seconds = 1.0;    ///< from the start to the analysed part
  double analysis_seconds = 1.0;  ///< the analysed part
};

/// The probe frequencies `evaluate` runs by default: 40, 80, 160 and 320 Hz (the thesis's).
std::vector<double> evaluation_probe_hz();

/// Throws std::invalid_argument, prefixed by `where`, for a probe frequency outside (0, fs/4): a probe's
/// second harmonic must lie below fs/2.
void require_probe_hz(const std::vector<double>& probe_hz, double fs, const std::string& where);

/// The program amplitude at which band-pass + feedforward `controller` reach a steady peak of `peak` at
/// `f` Hz, or `peak` itself where their gain is below 1 (evaluate's probe rule).
double probe_amplitude(const std::vector<dsp::Biquad>& band_pass, const StateSpace& controller, double f, double fs,
                       double peak);

/// A probe sine of `amplitude` at `f` Hz and rate fs, `timing.settle_seconds + timing.analysis_seconds` long.
Eigen::VectorXd probe_sine(double f, double amplitude, double fs, const ProbeTiming& timing = {});

/// THD in percent of the design's plant model (fb.plant) over the last `n_analysis` samples when driven by
/// `u` (the feedforward output): through the neural feedback in closed loop with it (fig. 7.10, model mode)
/// if `with_feedback`, else directly.
double model_probe_thd_pct(const NeuralFeedback& fb, const Eigen::VectorXd& u, bool with_feedback,
                           Eigen::Index n_analysis, double f, int harmonics);

/// Per probe in `probe_hz`: the change of the plant model's THD, in dB, that the neural feedback `fb` makes
/// behind band-pass + `ff` (20·log10 of THD with over THD without) at the probe amplitude for a steady
/// feedforward peak of `peak`; negative is a cut. Throws std::invalid_argument for a probe outside
/// (0, fs/4) or a peak outside (0, 1].
std::vector<double> model_thd_change_db(const NeuralFeedback& fb, const LqFeedforward& ff,
                                        const std::vector<dsp::Biquad>& band_pass, const std::vector<double>& probe_hz,
                                        double peak, int harmonics = 5, const ProbeTiming& timing = {});

}  // namespace panelbass::models

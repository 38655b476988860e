#include "evaluation/chain_evaluation.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

#include "dsp/biquad.h"
#include "dsp/butterworth.h"
#include "dsp/random.h"
#include "dsp/spectrum.h"
#include "engine/offline_renderer.h"
#include "models/control/feedback_training.h"
#include "models/control/lq_feedforward.h"
#include "models/control/model_probes.h"
#include "models/control/neural_feedback.h"
#include "models/linear/state_space.h"
#include "models/validation/performance.h"

namespace panelbass::evaluation {

using namespace engine;  // the chain under evaluation
namespace {

// Samples at the start of a noise run left out of J_c (the chain and the plant start at rest).
constexpr Eigen::Index kNoiseSkip = 1000;
// A probe sine fades in, settles, and is analysed over a whole second (models::ProbeTiming's defaults).
constexpr models::ProbeTiming kProbeTiming{};

std::vector<dsp::Biquad> band_pass_sections(const BandPassConfig& bp, double fs) {
  if (bp.bypass) return {};
  const BandPassDesign& d = bp.design;
  return dsp::butterworth_band(d.order, d.low.value, d.high.value, fs);
}

/// Which stages a row runs.
struct Variant {
  const char* name;
  bool band_pass, feedforward, feedback;
};

/// Renders `program` through `config` (with `variant`'s stages) into the plant.
struct Run {
  Rendering rendering;
  std::uint64_t faults = 0;
};

Run run_variant(const ChainConfig& config, const Variant& variant, const models::PlantConfig& plant,
                const Eigen::VectorXd& program, std::uint64_t seed) {
  ChainConfig c = config;
  c.band_pass.bypass = config.band_pass.bypass || !variant.band_pass;
  if (c.feedforward) c.feedforward->bypass = config.feedforward->bypass || !variant.feedforward;
  if (c.feedback) c.feedback->bypass = config.feedback->bypass || !variant.feedback;
  std::unique_ptr<Chain> chain = make_chain(c);
  RenderOptions ro;
  ro.block = Samples{c.block};
  ro.plant = plant;
  ro.noise_seed = seed;
  Run run{render(*chain, program, ro), 0};
  run.faults = chain->metrics().snapshot().faults;
  return run;
}

/// A response |program → y| by H1 (Welch), in dB.
struct Response {
  Eigen::VectorXd hz, db;
};

Response measure_response(const Eigen::VectorXd& program, const Eigen::VectorXd& y, double fs) {
  const dsp::FrequencyResponse frf = dsp::h1_frf(program, y, fs, dsp::WelchSpec{1024, 0.5});
  return {frf.frequency, frf.h.cwiseAbs().array().log10() * 20.0};
}

/// max − min of `r` over the ripple band, dB.
double ripple_db(const Response& r, const EvaluationOptions& o) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (Eigen::Index i = 0; i < r.hz.size(); ++i) {
    const double f = r.hz[i];
    if (f < o.ripple_low_hz || f > o.ripple_high_hz) continue;
    lo = std::min(lo, r.db[i]);
    hi = std::max(hi, r.db[i]);
  }
  return hi - lo;
}

/// `y` with its mean removed (an accelerometer is AC-coupled).
Eigen::VectorXd ac_coupled(const Eigen::VectorXd& y) { return y.array() - y.mean(); }

/// The THD of the design's plant model (fb.plant, NARX or ss) driven as `variant` drives the transducer: `sine`
/// through the band-pass and the [7B] feedforward, then the neural feedback in closed loop with the model
/// (fig. 7.10, model mode). The chain's limiter is left out: at a probe's drive it passes the drive unchanged.
double model_thd_pct(const models::NeuralFeedback& fb, const Variant& variant, const std::vector<dsp::Biquad>& sections,
                     const models::StateSpace& controller, const Eigen::VectorXd& sine, Eigen::Index n_analysis,
                     double f, int harmonics) {
  Eigen::VectorXd u = sine;
  if (variant.band_pass) u = dsp::SosFilter(sections).process(u);
  if (variant.feedforward) u = models::simulate(controller, u);
  return models::model_probe_thd_pct(fb, u, variant.feedback, n_analysis, f, harmonics);
}

void require_options(const EvaluationOptions& o, double fs) {
  if (!(o.ripple_low_hz >= 0.0 && o.ripple_low_hz < o.ripple_high_hz && o.ripple_high_hz <= fs / 2.0)) {
    throw std::invalid_argument("evaluate: the ripple band must satisfy 0 <= low < high <= fs/2");
  }
  if (o.noise_samples < 4096) throw std::invalid_argument("evaluate: noise_samples must be >= 4096");
  if (!(o.probe_peak >= 0.0 && o.probe_peak <= 1.0)) throw std::invalid_argument("evaluate: probe_peak must be within [0, 1]");
  if (o.harmonics < 3) throw std::invalid_argument("evaluate: at least 3 harmonics are needed for H2 and H3");
  models::require_probe_hz(o.probe_hz, fs, "evaluate");
}

}  // namespace

ChainEvaluation evaluate_chain(const ChainConfig& config, const models::PlantConfig& plant,
                               const EvaluationOptions& o) {
  const double fs = config.fs;
  require_options(o, fs);
  if (!config.feedforward || config.feedforward->model.value("kind", "") != "lq_feedforward") {
    throw std::invalid_argument(
        "evaluate: the chain needs a feedforward stage of kind lq_feedforward (its desired response is the J_c "
        "reference)");
  }
  const models::LqFeedforward ff = models::lq_feedforward_from_json(config.feedforward->model);
  const std::vector<dsp::Biquad> sections = band_pass_sections(config.band_pass, fs);
  const models::StateSpace controller = ff.controller();

  ChainEvaluation result;
  result.noise_amplitude = models::max_input(ff, sections, o.noise_samples, o.seed).noise;
  dsp::Rng rng(o.seed);
  Eigen::VectorXd noise(o.noise_samples);
  for (Eigen::Index k = 0; k < noise.size(); ++k) noise[k] = rng.uniform(-result.noise_amplitude, result.noise_amplitude);
  dsp::SosFilter band_pass(sections);
  const Eigen::VectorXd y_desired = models::simulate(ff.desired(), band_pass.process(noise));
  const double desired_power = y_desired.tail(y_desired.size() - kNoiseSkip).squaredNorm() /
                               static_cast<double>(y_desired.size() - kNoiseSkip);
  // [2C]'s floor: the sensor's noise power against the desired output's (per sample).
  result.jc_noise_floor_pct =
      models::j_ratio_percent(plant.sensor.noise_rms_V * plant.sensor.noise_rms_V, desired_power, "the desired output");
  models::PlantConfig quiet_plant = plant;
  quiet_plant.sensor.noise_rms_V = 0.0;

  // The design's plant model, when the chain's feedback stage is a neural feedback controller.
  std::optional<models::NeuralFeedback> design;
  if (config.feedback && config.feedback->model.value("kind", "") == "neural_feedback") {
    design = models::neural_feedback_from_json(config.feedback->model);
  }

  std::vector<Variant> variants{{"plant", false, false, false}, {"band-pass + feedforward", true, true, false}};
  if (config.feedback) variants.push_back({"band-pass + feedforward + feedback", true, true, true});

  const auto n_settle = static_cast<Eigen::Index>(kProbeTiming.settle_seconds * fs);
  const auto n_analysis = static_cast<Eigen::Index>(kProbeTiming.analysis_seconds * fs);
  for (const Variant& variant : variants) {
    EvaluationRow row;
    row.name = variant.name;
    Eigen::Index railed = 0, drive_samples = 0;
    const auto account = [&](const Run& run) {
      const Eigen::VectorXd& d = run.rendering.drive;
      row.max_drive = std::max(row.max_drive, d.cwiseAbs().maxCoeff());
      railed += (d.array().abs() > config.limiter.knee).count();
      drive_samples += d.size();
      row.faults += run.faults;
    };
    const Run noise_run = run_variant(config, variant, plant, noise, o.seed);
    account(noise_run);
    const Eigen::VectorXd y = ac_coupled(noise_run.rendering.clean);
    const Eigen::VectorXd y_measured = ac_coupled(noise_run.rendering.measured);
    row.jc_pct = models::jc_percent(y, y_desired, kNoiseSkip);
    row.measured_jc_pct = models::jc_percent(y_measured, y_desired, kNoiseSkip);
    Response response = measure_response(noise, y, fs);
    row.ripple_db = ripple_db(response, o);
    row.measured_ripple_db = ripple_db(measure_response(noise, y_measured, fs), o);
    row.response_hz = std::move(response.hz);
    row.response_db = std::move(response.db);
    const Run rest_run = run_variant(config, variant, quiet_plant, Eigen::VectorXd::Zero(n_settle + n_analysis), o.seed);
    row.rest_drive_peak = rest_run.rendering.drive.tail(n_analysis).cwiseAbs().maxCoeff();

    for (double f : o.probe_hz) {
      ProbeResult probe;
      probe.frequency_hz = f;
      // the amplitude at which band-pass + feedforward reach the steady peak (the bare plant row sees no
      // more than the peak either)
      const double peak = o.probe_peak > 0.0 ? o.probe_peak : config.limiter.knee;
      probe.amplitude = models::probe_amplitude(sections, controller, f, fs, peak);
      const Eigen::VectorXd sine = models::probe_sine(f, probe.amplitude, fs, kProbeTiming);
      const Run sine_run = run_variant(config, variant, quiet_plant, sine, o.seed);
      account(sine_run);
      const dsp::HarmonicLevels levels =
          dsp::harmonic_levels(sine_run.rendering.measured.tail(n_analysis), fs, f, o.harmonics);
      probe.drive_peak = sine_run.rendering.drive.tail(n_analysis).cwiseAbs().maxCoeff();
      probe.h2_db = levels.relative_db(2);
      probe.h3_db = levels.relative_db(3);
      probe.thd_pct = levels.thd_percent();
      for (std::size_t h = 2; h <= levels.amplitude.size(); ++h) probe.harmonics_db.push_back(levels.relative_db(h));
      if (design) {
        probe.model_thd_pct = model_thd_pct(*design, variant, sections, controller, sine, n_analysis, f, o.harmonics);
      }
      row.probes.push_back(probe);
    }
    row.rail_fraction = static_cast<double>(railed) / static_cast<double>(drive_samples);
    result.rows.push_back(std::move(row));
  }
  return result;
}

}  // namespace panelbass::evaluation

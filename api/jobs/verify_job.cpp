#include "api/jobs/verify_job.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "api/jobs/job_progress.h"
#include "api/jobs/lq_band_pass.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/stored_models.h"
#include "dsp/excitation.h"
#include "dsp/harmonics.h"
#include "engine/chain_file.h"
#include "models/control/lq_feedforward.h"
#include "models/io/json_fields.h"
#include "models/io/number_text.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// How long a probe may play, by default, when its THD is read too noisily at `seconds`.
constexpr double kDefaultMaxSeconds = 8.0;
// A THD read within this (one standard deviation of the sensor noise's share, dB) is kept; a noisier one is
// measured again, longer, up to max_seconds: the card and the virtual backend then agree well within 1 dB.
constexpr double kThdUncertaintyDb = 0.2;
// A THD the noise still moves by more than this at max_seconds is given as a bound, not a number.
constexpr double kMaxUncertaintyDb = 1.0;

json verify_params(const json& params, const JobEnvironment& env) {
  if (!env.excite && !env.measure) refuse("params", "this server has no backend to play the probe tones through");
  ParamReader r(params, "params");
  require_stored_model(r, "feedforward_model", true, {"lq_feedforward"}, env);
  require_stored_model(r, "feedback_model", false, {"neural_feedback"}, env);
  r.numbers("frequencies", {40.0, 80.0, 160.0}, 1, 16, {10.0, env.fs / 4.0, true, true});
  r.number("level", std::min(0.2, env.safe_level), {0.0, env.safe_level, false, true});
  const double seconds = r.number("seconds", 0.5, {0.1, 10.0, true, true});
  r.number("max_seconds", std::max(seconds, kDefaultMaxSeconds), {seconds, 30.0, true, true});
  return r.finish();
}

// The chain's drive for `program`: band-pass (as the feedforward was designed behind), the feedforward, the
// feedback in model mode when given, the limiter — run offline exactly as the engine runs it.
Eigen::VectorXd chain_drive(const json& feedforward, const json* feedback, const Eigen::VectorXd& program, double fs) {
  const LqBandPass band = lq_band_pass(models::lq_feedforward_from_json(feedforward));
  json chain = {{"format", engine::kChainFormat},
                {"fs", fs},
                {"band_pass", {{"low_hz", band.low_hz}, {"high_hz", band.high_hz}, {"order", band.order}}},
                {"feedforward", {{"model", feedforward}}}};
  if (feedback != nullptr) chain["feedback"] = {{"model", *feedback}, {"source", "model"}};
  const std::unique_ptr<engine::Chain> run = engine::make_chain(engine::chain_config_from_json(chain, "."));
  Eigen::VectorXd drive(program.size());
  const Eigen::Index block = run->options().spec.max_block;
  for (Eigen::Index k = 0; k < program.size(); k += block) {
    const Eigen::Index n = std::min(block, program.size() - k);
    run->process_block(std::span<const double>(program.data() + k, static_cast<std::size_t>(n)),
                       std::span<double>(drive.data() + k, static_cast<std::size_t>(n)));
  }
  return drive;
}

// Plays `drive` through the backend: the measured response.
Eigen::VectorXd played(const JobEnvironment& env, const Eigen::VectorXd& drive) {
  return env.measure ? env.measure(drive).y : env.excite(drive);
}

// One side of a probe (without or with the chain) as measured: its THD and the noise it stands on.
struct ProbeReading {
  dsp::SteadyThd thd;
  Eigen::VectorXd response;
  double seconds = 0.0;
};

// Plays `drive_of(samples)` for `seconds`, then again longer while its THD is read with more than
// kThdUncertaintyDb of noise (the length grown as the noise's share falls, ∝ 1/N) or is at the noise floor
// (then for `max_seconds`), never longer than `max_seconds`. Throws when no THD can be read.
ProbeReading read_probe(const JobEnvironment& env, const std::function<Eigen::VectorXd(std::size_t)>& drive_of,
                        double frequency, double seconds, double max_seconds, const std::string& what) {
  ProbeReading r;
  for (double s = seconds;;) {
    const auto samples = static_cast<std::size_t>(std::llround(s * env.fs));
    r.response = played(env, drive_of(samples));
    r.seconds = s;
    const std::optional<dsp::SteadyThd> thd = dsp::steady_thd(r.response, env.fs, frequency);
    if (!thd) {
      throw std::runtime_error("the " + models::number_text(frequency) + " Hz probe " + what + ": no THD in " +
                               models::number_text(s) + " s (params.seconds)");
    }
    r.thd = *thd;
    if ((!r.thd.at_floor && r.thd.uncertainty_db <= kThdUncertaintyDb) || s >= max_seconds) return r;
    // At the floor: as long as allowed (the floor falls as 1/√N, and the THD may stand above it then).
    const double grow = r.thd.at_floor ? max_seconds / s : r.thd.uncertainty_db / kThdUncertaintyDb;
    s = std::min(max_seconds, s * std::max(1.5, 1.2 * grow * grow));
  }
}

// Whether a reading is the noise's rather than the THD's: within 3 dB of its floor, or moved by the noise by
// more than kMaxUncertaintyDb even at max_seconds.
bool noise_bound(const ProbeReading& r) { return r.thd.at_floor || r.thd.uncertainty_db > kMaxUncertaintyDb; }

// What a noise-bound reading's THD is at most: √2 times its floor (within 3 dB of it), or two standard
// deviations of its noise above what it read.
double thd_at_most(const ProbeReading& r) {
  return r.thd.at_floor ? std::sqrt(2.0) * r.thd.floor_pct : r.thd.thd_pct * std::pow(10.0, 2.0 * r.thd.uncertainty_db / 20.0);
}

// A reading's THD (null when noise-bound) and what stands beside it, under `side` ("before"/"after").
void put_reading(json& row, const std::string& side, const ProbeReading& r) {
  row["thd_" + side + "_pct"] = noise_bound(r) ? json(nullptr) : json(r.thd.thd_pct);
  row["thd_" + side + "_floor_pct"] = r.thd.floor_pct;
  row["thd_" + side + "_at_floor"] = noise_bound(r);
  if (noise_bound(r)) row["thd_" + side + "_at_most_pct"] = thd_at_most(r);
  row["thd_" + side + "_uncertainty_db"] = models::number_or_null(r.thd.uncertainty_db);
  row["seconds_" + side] = r.seconds;
}

json verify_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const json feedforward = stored_model_file(env, params.at("feedforward_model").get<std::string>());
  const json feedback_file = params.contains("feedback_model") && params.at("feedback_model").is_string()
                                 ? stored_model_file(env, params.at("feedback_model").get<std::string>())
                                 : json();
  const json* feedback = feedback_file.is_null() ? nullptr : &feedback_file;
  const std::vector<double> tones = params.at("frequencies").get<std::vector<double>>();
  const double level = params.at("level").get<double>();
  const double seconds = params.at("seconds").get<double>(), max_seconds = params.at("max_seconds").get<double>();
  json rows = json::array();
  std::vector<std::string> warnings;  // a probe the chain makes worse, said in words
  for (std::size_t t = 0; t < tones.size(); ++t) {
    const double f = tones[t];
    progress.at(static_cast<double>(t) / static_cast<double>(tones.size()), "probe " + models::number_text(f) + " Hz");
    double drive_peak = 0.0;
    const auto program = [&](std::size_t samples) { return dsp::sine(samples, env.fs, f, level); };
    const auto chained = [&](std::size_t samples) {
      const Eigen::VectorXd drive = chain_drive(feedforward, feedback, program(samples), env.fs);
      drive_peak = drive.cwiseAbs().maxCoeff();
      if (drive_peak > env.safe_level) {
        throw std::runtime_error("the chain's drive for the " + models::number_text(f) + " Hz probe peaks at " +
                                 models::number_text(drive_peak) + ", beyond the safe level " +
                                 models::number_text(env.safe_level) + ": lower params.level");
      }
      return drive;
    };
    const ProbeReading before = read_probe(env, program, f, seconds, max_seconds, "without the chain");
    const ProbeReading after = read_probe(env, chained, f, seconds, max_seconds, "through the chain");
    const auto level_of = [&](const Eigen::VectorXd& y) {
      const Eigen::Index n = y.size() / 2;  // the steady second half
      return dsp::harmonic_levels(y.tail(n), env.fs, f, 1).amplitude[0];
    };
    json row = {{"frequency_hz", f},
                {"level_before", level_of(before.response)},
                {"level_after", level_of(after.response)},
                {"drive_peak_after", drive_peak}};
    put_reading(row, "before", before);
    put_reading(row, "after", after);
    // A noise-bound THD is not a number to compare: the change is then a bound (thd_at_most), or unknown when
    // the THD before is noise-bound too.
    const double thd_before = before.thd.thd_pct, thd_after = after.thd.thd_pct;
    if (!noise_bound(before) && !noise_bound(after) && thd_after > 0.0) {
      const double change = 20.0 * std::log10(thd_after / thd_before);
      row["thd_change_db"] = change;
      row["thd_cut_db"] = -change;  // positive: less distortion
      if (change > 0.0) {
        warnings.push_back("at " + models::number_text(f) + " Hz the chain makes the distortion worse: THD " +
                           models::number_text(thd_before, 3) + " % → " + models::number_text(thd_after, 3) + " % (+" +
                           models::number_text(change, 3) + " dB, at equal program level: the response's level " +
                           models::number_text(level_of(before.response), 3) + " → " +
                           models::number_text(level_of(after.response), 3) + "); leave this controller out or redesign it");
      }
    } else if (!noise_bound(before)) {
      const double bound = 20.0 * std::log10(thd_at_most(after) / thd_before);
      row["thd_change_db"] = nullptr;
      row["thd_change_at_most_db"] = bound;
      row["note"] = "the THD through the chain is at the sensor's noise floor (at most " +
                    models::number_text(thd_at_most(after)) + " %): a change of at most " + models::number_text(bound) + " dB";
    } else {
      row["thd_change_db"] = nullptr;
      row["note"] = "the THD without the chain is at the sensor's noise floor (" + models::number_text(before.thd.floor_pct) +
                    " %): a louder probe (params.level) or longer (params.max_seconds) shows the change";
    }
    rows.push_back(row);
  }
  progress.at(1.0, "done");
  return {{"fs", env.fs},
          {"level", level},
          {"backend", env.measure ? "alsa" : "virtual"},
          {"probes", rows},
          {"warnings", warnings}};
}

}  // namespace

JobKind verify_job() { return {"verify", verify_params, verify_work}; }

}  // namespace panelbass::api

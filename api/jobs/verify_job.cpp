#include "api/jobs/verify_job.h"

#include <cmath>
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
#include "models/io/number_text.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

json verify_params(const json& params, const JobEnvironment& env) {
  if (!env.excite && !env.measure) refuse("params", "this server has no backend to play the probe tones through");
  ParamReader r(params, "params");
  require_stored_model(r, "feedforward_model", true, {"lq_feedforward"}, env);
  require_stored_model(r, "feedback_model", false, {"neural_feedback"}, env);
  r.numbers("frequencies", {40.0, 80.0, 160.0}, 1, 16, {10.0, env.fs / 4.0, true, true});
  r.number("level", std::min(0.2, env.safe_level), {0.0, env.safe_level, false, true});
  r.number("seconds", 0.5, {0.1, 10.0, true, true});
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

json verify_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const json feedforward = stored_model_file(env, params.at("feedforward_model").get<std::string>());
  const json feedback_file = params.contains("feedback_model") && params.at("feedback_model").is_string()
                                 ? stored_model_file(env, params.at("feedback_model").get<std::string>())
                                 : json();
  const json* feedback = feedback_file.is_null() ? nullptr : &feedback_file;
  const std::vector<double> tones = params.at("frequencies").get<std::vector<double>>();
  const double level = params.at("level").get<double>();
  const auto samples = static_cast<std::size_t>(std::llround(params.at("seconds").get<double>() * env.fs));
  json rows = json::array();
  for (std::size_t t = 0; t < tones.size(); ++t) {
    const double f = tones[t];
    progress.at(static_cast<double>(t) / static_cast<double>(tones.size()), "probe " + models::number_text(f) + " Hz");
    const Eigen::VectorXd program = dsp::sine(samples, env.fs, f, level);
    const Eigen::VectorXd drive = chain_drive(feedforward, feedback, program, env.fs);
    if (drive.cwiseAbs().maxCoeff() > env.safe_level) {
      throw std::runtime_error("the chain's drive for the " + models::number_text(f) + " Hz probe peaks at " +
                               models::number_text(drive.cwiseAbs().maxCoeff()) + ", beyond the safe level " +
                               models::number_text(env.safe_level) + ": lower params.level");
    }
    const Eigen::VectorXd before = played(env, program), after = played(env, drive);
    const std::optional<double> thd_before = dsp::steady_thd_percent(before, env.fs, f);
    const std::optional<double> thd_after = dsp::steady_thd_percent(after, env.fs, f);
    const auto level_of = [&](const Eigen::VectorXd& y) {
      const Eigen::Index n = y.size() / 2;  // the steady second half
      return dsp::harmonic_levels(y.tail(n), env.fs, f, 1).amplitude[0];
    };
    json row = {{"frequency_hz", f},
                {"thd_before_pct", thd_before ? json(*thd_before) : json(nullptr)},
                {"thd_after_pct", thd_after ? json(*thd_after) : json(nullptr)},
                {"level_before", level_of(before)},
                {"level_after", level_of(after)},
                {"drive_peak_after", drive.cwiseAbs().maxCoeff()}};
    if (thd_before && thd_after && *thd_before > 0.0 && *thd_after > 0.0) {
      row["thd_change_db"] = 20.0 * std::log10(*thd_after / *thd_before);
    }
    rows.push_back(row);
  }
  progress.at(1.0, "done");
  return {{"fs", env.fs}, {"level", level}, {"backend", env.measure ? "alsa" : "virtual"}, {"probes", rows}};
}

}  // namespace

JobKind verify_job() { return {"verify", verify_params, verify_work}; }

}  // namespace panelbass::api

#include "api/jobs/model_judgement.h"

#include <algorithm>
#include <limits>
#include <utility>
#include <vector>

#include "api/jobs/job_plots.h"
#include "dsp/sample_rate.h"
#include "models/validation/performance.h"

namespace panelbass::api {
namespace {

// Stepped-sine fundamentals (Hz) of the harmonics plot, and its samples per step.
const std::vector<double> kHarmonicFrequencies{50.0, 100.0, 200.0, 400.0};
constexpr std::size_t kHarmonicSettle = 300, kHarmonicMeasure = 1500;

double peak(const Eigen::VectorXd& x) { return x.size() ? x.cwiseAbs().maxCoeff() : 0.0; }

}  // namespace

Eigen::Index init_samples(Eigen::Index samples) { return std::min<Eigen::Index>(kInit, samples / 10); }

double simulation_j(const models::AnyModel& model, const Eigen::VectorXd& u, const Eigen::VectorXd& y) {
  if (u.size() == 0) return std::numeric_limits<double>::quiet_NaN();
  const Eigen::Index init = init_samples(u.size());
  return models::j_percent(model.simulate(u, y, init), y, init);
}

nlohmann::json model_plots(const models::AnyModel& model, const ExcitationRecord& r, double fs) {
  const JudgedPart part = judged_part(r);
  const Eigen::Index init = init_samples(part.u.size());
  const Eigen::VectorXd y_sim = model.simulate(part.u, part.y, init);
  const Eigen::Index n = part.u.size() - init;
  return {{"fit", fit_plot(part.y.tail(n), y_sim.tail(n), fs, init)},
          {"spectrum", spectrum_plot(part.u, part.y, model.simulate(part.u), fs)}};
}

nlohmann::json identified_model_result(const std::string& model_id, const nlohmann::json& summary,
                                       const std::vector<std::string>& warnings, const JudgedPart& part,
                                       const Eigen::VectorXd& y_sim, double fs) {
  return identified_model_result(
      model_id, summary, warnings,
      {{"fit", fit_plot(part.y, y_sim, fs)}, {"spectrum", spectrum_plot(part.u, part.y, y_sim, fs)}});
}

nlohmann::json identified_model_result(const std::string& model_id, const nlohmann::json& summary,
                                       const std::vector<std::string>& warnings, nlohmann::json plots) {
  return {{"model_id", model_id},
          {"j_est_pct", summary.at("J_est_pct")},
          {"j_val_pct", summary.at("J_val_pct")},
          {"summary", summary},
          {"warnings", warnings},
          {"plots", std::move(plots)}};
}

std::optional<models::DistortionSpec> harmonic_spec(const JobEnvironment& env, double model_fs,
                                                    const ExcitationRecord& r) {
  if (!env.plant || !dsp::same_rate(env.plant->fs, model_fs)) return std::nullopt;
  models::DistortionSpec spec;
  spec.frequencies = kHarmonicFrequencies;
  spec.amplitudes = {std::clamp(peak(r.u_est), 1e-3, 1.0)};
  spec.settle = kHarmonicSettle;
  spec.measure = kHarmonicMeasure;
  spec.max_order = 3;
  return spec;
}

nlohmann::json harmonics_if_known(const JobEnvironment& env, const models::AnyModel& model, const ExcitationRecord& r,
                                  JobProgress& progress) {
  const std::optional<models::DistortionSpec> spec = harmonic_spec(env, model.fs(), r);
  if (!spec) return nullptr;
  progress.at(0.0, "harmonic distortion of plant and model");
  return harmonics_plot(models::compare_distortion(*env.plant, model, *spec));
}

}  // namespace panelbass::api

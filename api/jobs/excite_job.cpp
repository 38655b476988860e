#include "api/jobs/excite_job.h"

#include <cmath>

#include "api/jobs/excitation_record.h"
#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/record_acquisition.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The excite kind's own params are an excitation's.
json excite_job_params(const json& params, const JobEnvironment& env) { return excite_params(params, "params", env); }

// RMS over both parts of a record.
double rms(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::Index n = a.size() + b.size();
  return n > 0 ? std::sqrt((a.squaredNorm() + b.squaredNorm()) / static_cast<double>(n)) : 0.0;
}

json excite_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  progress.span(0.0, 0.95);
  const ExcitationRecord r = run_excitation(params, env, progress);
  const Eigen::Index n = std::min<Eigen::Index>(2000, r.u_est.size());
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(n, 0.0, static_cast<double>(n - 1)) / env.fs;
  json result = {{"fs", env.fs},
                 {"signal", params.at("signal")},
                 {"amplitude", params.at("amplitude")},
                 {"seed", params.at("seed")},
                 {"samples", r.u_est.size()},
                 {"validation_samples", r.u_val.size()},
                 {"rms_drive", rms(r.u_est, r.u_val)},
                 {"rms_response", rms(r.y_est, r.y_val)},
                 {"plots",
                  {{"fit", {{"t", column(t)}, {"drive", column(r.u_est.head(n))}, {"measured", column(r.y_est.head(n))}}}}},
                 {"record", excitation_record_to_json(r)}};
  if (!r.card.is_null()) result["card"] = r.card;
  progress.span(0.0, 1.0);
  progress.at(1.0, "done");
  return result;
}

}  // namespace

JobKind excite_job() { return {"excite", excite_job_params, excite_work}; }

}  // namespace panelbass::api

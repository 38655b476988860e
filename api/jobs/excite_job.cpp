#include "api/jobs/excite_job.h"

#include <algorithm>
#include <string>

#include "api/jobs/excitation_record.h"
#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/record_acquisition.h"
#include "api/record_store.h"
#include "api/record_upload.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The excite kind's own params are an excitation's.
json excite_job_params(const json& params, const JobEnvironment& env) { return excite_params(params, "params", env); }

// Keeps the record once in the record store, the result naming it ("record_id", "record_columns"; a few hundred
// bytes instead of megabytes in the job file and in every answer about the job); inline ("record") where there is
// no record store or the store takes no record of its length.
void keep_record(const ExcitationRecord& r, const JobEnvironment& env, const JobControl& control, json& result) {
  const auto total = static_cast<std::size_t>(r.u_est.size() + r.u_val.size());
  if (env.records == nullptr || total < kMinRecordSamples || total > kMaxRecordSamples) {
    result["record"] = excitation_record_to_json(r);
    return;
  }
  RecordUpload upload;
  upload.content_type = "text/csv";
  upload.fs = env.fs;
  upload.input = "u";
  upload.output = "y";
  upload.current = r.i_est.size() > 0 ? "i" : "";
  const StoredRecord stored =
      env.records->put(excitation_record_csv(r), upload, "excitation of " + control.job_id(), env.fs);
  result["record_id"] = stored.id;
  result["record_columns"] = excitation_record_columns(r);
}

json excite_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  progress.span(0.0, 0.95);
  const usecases::ExciteReport report =
      usecases::excite(excite_request(params, env, true), excitation_play(env), progress);
  const ExcitationRecord& r = report.record;
  const Eigen::Index n = std::min<Eigen::Index>(2000, r.u_est.size());
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(n, 0.0, static_cast<double>(n - 1)) / env.fs;
  json result = report.summary;
  result["plots"] = {{"fit", {{"t", column(t)}, {"drive", column(r.u_est.head(n))}, {"measured", column(r.y_est.head(n))}}}};
  keep_record(r, env, control, result);
  if (!r.card.is_null()) result["card"] = r.card;
  progress.span(0.0, 1.0);
  progress.at(1.0, "done");
  return result;
}

}  // namespace

JobKind excite_job() { return {"excite", excite_job_params, excite_work}; }

}  // namespace panelbass::api

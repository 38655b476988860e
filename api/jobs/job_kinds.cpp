#include "api/jobs/job_kinds.h"

#include <stdexcept>

#include "api/jobs/analyze_job.h"
#include "api/jobs/design_lq_job.h"
#include "api/jobs/design_mirror_job.h"
#include "api/jobs/design_nn_job.h"
#include "api/jobs/diagnose_job.h"
#include "api/jobs/evaluate_job.h"
#include "api/jobs/excite_job.h"
#include "api/jobs/identify_linear_job.h"
#include "api/jobs/harmonics_job.h"
#include "api/jobs/identify_average_job.h"
#include "api/jobs/identify_mimo_job.h"
#include "api/jobs/identify_narx_job.h"
#include "api/jobs/identify_oscillator_job.h"
#include "api/jobs/identify_ss_job.h"
#include "api/jobs/job_kind.h"
#include "api/jobs/job_plots.h"
#include "api/jobs/plant_survey_job.h"
#include "api/jobs/tune_job.h"
#include "api/jobs/validate_job.h"
#include "api/jobs/verify_job.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// Every kind, in the order the OpenAPI document lists them (a server test compares the two).
const std::vector<JobKind>& registry() {
  static const std::vector<JobKind> kinds{excite_job(),     identify_linear_job(), identify_narx_job(),
                                          identify_oscillator_job(), identify_ss_job(), identify_average_job(),
                                          identify_mimo_job(), validate_job(),   design_lq_job(),       design_nn_job(),
                                          design_mirror_job(), evaluate_job(),     analyze_job(),
                                          harmonics_job(),  diagnose_job(),        verify_job(),
                                          tune_job(),       plant_survey_job()};
  return kinds;
}

// The kind named `name`; std::invalid_argument "kind: …" listing the known ones when there is none.
const JobKind& kind_named(const std::string& name) {
  for (const JobKind& kind : registry()) {
    if (name == kind.name) return kind;
  }
  std::string expected;
  for (const std::string& k : job_kinds()) expected += (expected.empty() ? "" : ", ") + k;
  throw std::invalid_argument("kind: unknown job kind \"" + name + "\"; expected one of " + expected);
}

}  // namespace

const std::vector<std::string>& job_kinds() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const JobKind& kind : registry()) out.emplace_back(kind.name);
    return out;
  }();
  return names;
}

std::string model_kind_made_by(const std::string& job_kind) {
  for (const JobKind& kind : registry()) {
    if (job_kind == kind.name) return kind.makes != nullptr ? kind.makes : "";
  }
  return "";
}

bool activates_by_default(const std::string& job_kind) {
  for (const JobKind& kind : registry()) {
    if (job_kind == kind.name) return kind.activates_by_default;
  }
  return false;
}

json validate_job_params(const std::string& kind, const json& params, const JobEnvironment& env) {
  return kind_named(kind).params(params, env);
}

JobWork job_work(const std::string& kind, const JobEnvironment& env) {
  const KindWork work = kind_named(kind).work;
  return [work, env](const json& params, JobControl& control) { return without_non_finite(work(params, env, control)); };
}

}  // namespace panelbass::api

#include "api/jobs/identify_oscillator_job.h"

#include <limits>
#include <string>

#include "api/jobs/model_judgement.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/record_acquisition.h"
#include "api/jobs/stored_models.h"
#include "usecases/identify_oscillator.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// The request of filled-in params, without its records.
usecases::IdentifyOscillatorRequest oscillator_request(const json& params) {
  usecases::IdentifyOscillatorRequest q;
  q.terms = params.at("terms").get<std::vector<std::string>>();
  q.substeps = params.at("substeps").get<int>();
  q.output_taps = params.at("output_taps").get<int>();
  q.input_taps = params.at("input_taps").get<int>();
  q.max_iterations = params.at("max_iterations").get<int>();
  q.init = params.at("init").get<long>();
  q.delay = params.at("delay").get<bool>();
  return q;
}

json identify_oscillator_params(const json& params, const JobEnvironment& env) {
  const usecases::IdentifyOscillatorRequest defaults;
  ParamReader r(params, "params");
  std::string validation_path;
  record_source(r, env, validation_path);
  const json* terms = r.member("terms");
  if (terms == nullptr || terms->is_null()) {
    r.set("terms", defaults.terms);
  } else {
    if (!terms->is_array()) refuse(r.path_of("terms"), "expected an array of term names, got " + shown(*terms));
    for (const json& t : *terms) {
      if (!t.is_string()) refuse(r.path_of("terms"), "expected term names (strings), got " + shown(t));
    }
    r.set("terms", *terms);
  }
  r.integer("substeps", defaults.substeps, -kAnyInteger, kAnyInteger);
  r.integer("output_taps", defaults.output_taps, -kAnyInteger, kAnyInteger);
  r.integer("input_taps", defaults.input_taps, -kAnyInteger, kAnyInteger);
  r.integer("max_iterations", defaults.max_iterations, -kAnyInteger, kAnyInteger);
  r.integer("init", defaults.init, -kAnyInteger, kAnyInteger);
  r.boolean("delay", defaults.delay);
  json filled = r.finish();
  check_request([&] { usecases::check(oscillator_request(filled)); });
  return filled;
}

json identify_oscillator_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const SourcedRecord data = acquire_record(params, env, progress, control);
  usecases::IdentifyOscillatorRequest q = oscillator_request(params);
  put_record(q, data, env.fs);
  progress.span(kExcitationShare, 0.95);
  usecases::IdentifyOscillatorReport report;
  check_request([&] { report = usecases::identify_oscillator(q, progress); });
  const std::string model_id = store_model(env, models::oscillator_model_to_json(report.model),
                                           "oscillator on " + data.source + " (" + control.job_id() + ")", control);
  const JudgedPart part = judged_part(data.record);
  const Eigen::VectorXd y_sim = report.model.simulate(part.u, part.y, q.init);
  progress.span(0.0, 1.0);
  progress.at(1.0, "done");
  return identified_model_result(model_id, report.summary, report.warnings, part, y_sim, env.fs);
}

}  // namespace

JobKind identify_oscillator_job() {
  return {"identify-oscillator", identify_oscillator_params, identify_oscillator_work, "oscillator"};
}

}  // namespace panelbass::api

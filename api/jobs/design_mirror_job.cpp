#include "api/jobs/design_mirror_job.h"

#include <limits>
#include <stdexcept>
#include <string>

#include "api/jobs/job_progress.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/stored_models.h"
#include "dsp/excitation.h"
#include "models/plant/virtual_transducer.h"
#include "usecases/design_mirror.h"

namespace panelbass::api {
namespace {

using nlohmann::json;


// The excitation's defaults: `design mirror`'s example record (a multisine over the exciter's working band).
struct MirrorExcitation {
  long long samples = 30000;
  double amplitude = 0.5;
  double f_min = 10.0, f_max = 300.0;
};

json design_mirror_params(const json& params, const JobEnvironment& env) {
  if (!env.plant) {
    refuse("params", "design-mirror fits the drive, the coil current and the displacement, and only the virtual "
                     "transducer gives the displacement; this server plays a sound card");
  }
  const usecases::DesignMirrorRequest defaults;
  const MirrorExcitation excitation;
  ParamReader r(params, "params");
  r.integer("samples", excitation.samples, 1000, kMaxSamples);
  r.number("amplitude", excitation.amplitude, {0.0, env.safe_level, true, false});
  const double f_min = r.number("f_min", excitation.f_min, {0.0, env.fs / 2.0, true, true});
  r.number("f_max", excitation.f_max, {f_min, env.fs / 2.0, true, true});
  r.integer("seed", 1, 0, kMaxSeed);
  r.integer("max_delay", defaults.max_delay, std::numeric_limits<int>::min(), std::numeric_limits<int>::max());
  r.boolean("adapt", defaults.adapt);
  r.number("stiffness_rate", defaults.stiffness_rate, kAnyFinite);
  r.number("stiffness_spread", defaults.stiffness_spread, kAnyFinite);
  r.boolean("current_only", defaults.current_only);
  r.choice("sensor_kind", defaults.sensor_kind, {"none", "acceleration", "velocity", "displacement", "microphone"});
  json filled = r.finish();
  usecases::DesignMirrorRequest q;
  q.fs = env.fs;
  // Stand-in columns for the check of the other fields: the reader above already holds samples to 1000 and more, so
  // 1000 samples (not the record's millions) check the same.
  q.drive = q.current = q.displacement = q.sensor = Eigen::VectorXd::Zero(1000);
  q.max_delay = filled.at("max_delay").get<int>();
  q.adapt = filled.at("adapt").get<bool>();
  q.stiffness_rate = filled.at("stiffness_rate").get<double>();
  q.stiffness_spread = filled.at("stiffness_spread").get<double>();
  q.current_only = filled.at("current_only").get<bool>();
  q.sensor_kind = filled.at("sensor_kind").get<std::string>();
  check_request([&] { usecases::check(q); });
  return filled;
}

json design_mirror_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  progress.at(0.0, "exciting the virtual transducer");
  dsp::MultisineSpec spec;
  spec.period = static_cast<std::size_t>(params.at("samples").get<long>());
  spec.fs = env.fs;
  spec.f_min = params.at("f_min").get<double>();
  spec.f_max = params.at("f_max").get<double>();
  spec.amplitude = params.at("amplitude").get<double>();
  spec.seed = params.at("seed").get<std::uint64_t>();
  usecases::DesignMirrorRequest q;
  q.drive = dsp::multisine(spec).signal;
  const models::PlantRecord record = models::simulate(*env.plant, q.drive, spec.seed);
  q.current = record.i;
  q.displacement = record.x;
  q.sensor = record.y;
  q.fs = env.fs;
  q.data_name = "multisine on the server's virtual transducer (" + control.job_id() + ")";
  q.max_delay = params.at("max_delay").get<int>();
  q.adapt = params.at("adapt").get<bool>();
  q.stiffness_rate = params.at("stiffness_rate").get<double>();
  q.stiffness_spread = params.at("stiffness_spread").get<double>();
  q.current_only = params.at("current_only").get<bool>();
  q.sensor_kind = params.at("sensor_kind").get<std::string>();
  if (q.current_only) q.displacement.resize(0);  // the fit from the drive and the current: x is not given it
  progress.span(0.2, 0.95);
  const usecases::DesignMirrorReport report = usecases::design_mirror(q, progress);
  if (!report.usable) {
    std::string why;
    for (const std::string& w : report.warnings) why += (why.empty() ? "" : " ") + w;
    throw std::runtime_error("the fit misses this transducer, so no mirror filter is stored: " + why);
  }
  const std::string model_id = store_model(env, models::mirror_model_to_json(report.model, report.meta),
                                           "mirror filter (" + control.job_id() + ")", control);
  progress.span(0.0, 1.0);
  progress.at(1.0, "done");
  return {{"model_id", model_id},
          {"j_est_pct", nullptr},
          {"j_val_pct", nullptr},
          {"summary", report.summary},
          {"warnings", report.warnings},
          {"plots", json::object()}};
}

}  // namespace

JobKind design_mirror_job() { return {"design-mirror", design_mirror_params, design_mirror_work, "mirror_filter"}; }

}  // namespace panelbass::api

#include "api/jobs/analyze_job.h"

#include <limits>
#include <string>
#include <vector>

#include "api/jobs/job_plots.h"
#include "api/jobs/job_progress.h"
#include "api/jobs/model_judgement.h"
#include "api/jobs/param_reader.h"
#include "api/jobs/record_acquisition.h"
#include "api/jobs/stored_models.h"
#include "models/io/json_fields.h"
#include "models/kinds/model_file.h"
#include "models/plant/plant_presets.h"
#include "usecases/analyze.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The request of filled-in params, without its model, record and plant.
usecases::AnalyzeRequest analyze_request(const json& params) {
  usecases::AnalyzeRequest q;
  q.init = params.at("init").get<long>();
  q.lags = params.at("lags").get<int>();
  q.segment = params.at("segment").get<long>();
  q.refine_iterations = params.at("refine_iterations").get<int>();
  if (params.at("gain_range").is_array()) q.gain_range = params.at("gain_range").get<std::vector<double>>();
  q.frequencies = params.at("frequencies").get<std::vector<double>>();
  q.amplitudes = params.at("amplitudes").get<std::vector<double>>();
  q.measure = params.at("measure").get<long>();
  return q;
}

json analyze_params(const json& params, const JobEnvironment& env) {
  const usecases::AnalyzeRequest d;
  ParamReader r(params, "params");
  require_stored_model(r, "model", true, kinds_taking(models::ModelRole::plant), env);
  std::string validation_path;
  record_source(r, env, validation_path);
  r.integer("init", d.init, -kAnyInteger, kAnyInteger);
  r.integer("lags", d.lags, -kAnyInteger, kAnyInteger);
  r.integer("segment", d.segment, -kAnyInteger, kAnyInteger);
  r.integer("refine_iterations", d.refine_iterations, -kAnyInteger, kAnyInteger);
  if (const json* g = r.member("gain_range"); g == nullptr || g->is_null()) {
    r.set("gain_range", nullptr);
  } else {
    r.numbers("gain_range", {}, 0, 16, kAnyFinite);
  }
  // The plant the data came from, for harmonic distortion: the server's own virtual transducer (the default when it
  // runs one), a preset, or none.
  std::vector<std::string> plants = models::plant_preset_names();
  plants.push_back("none");
  if (env.plant) plants.insert(plants.begin(), "server");
  r.choice("plant", env.plant ? "server" : "none", plants);
  r.numbers("frequencies", d.frequencies, 0, 64, kAnyFinite);
  r.numbers("amplitudes", d.amplitudes, 0, 64, kAnyFinite);
  r.integer("measure", d.measure, -kAnyInteger, kAnyInteger);
  json filled = r.finish();
  check_request([&] { usecases::check(analyze_request(filled)); });
  return filled;
}

json analyze_work(const json& params, const JobEnvironment& env, JobControl& control) {
  JobProgress progress(control);
  const SourcedRecord data = acquire_record(params, env, progress, control);
  const ExcitationRecord& r = data.record;
  const JudgedPart part = judged_part(r);
  usecases::AnalyzeRequest q = analyze_request(params);
  q.model_name = params.at("model").get<std::string>();
  q.model = stored_model_file(env, q.model_name);
  q.u = part.u;
  q.y = part.y;
  q.data_name = data.source + (part.validation ? " (validation)" : " (estimation)");
  const std::string plant = params.at("plant").get<std::string>();
  if (plant == "server") {
    q.plant = env.plant;
  } else if (plant != "none") {
    q.plant = models::plant_preset(plant);
  }
  if (q.plant) q.plant_name = plant;
  progress.span(kExcitationShare, 0.95);
  usecases::AnalyzeReport report;
  check_request([&] { report = usecases::analyze(q, progress); });
  const models::ModelAnalysis& a = report.analysis;

  progress.span(0.95, 1.0);
  json plots = {{"fit", fit_plot(a.y, a.y_sim, env.fs, a.init)},
                {"spectrum", spectrum_plot(a.frf.frequency, a.frf.measured, a.frf.model)}};
  if (a.history) {
    std::vector<HistoryPoint> history;
    for (const auto& p : a.history->points) history.push_back({p.iteration, p.j_est_pct, p.j_val_pct});
    plots["history"] = history_plot(history);
  }
  if (a.distortion && a.kind == "narx") plots["harmonics"] = harmonics_plot(*a.distortion);
  const models::AnyModel model = models::model_from_json(q.model);
  const double j_est = part.validation ? simulation_j(model, r.u_est, r.y_est) : a.j_sim_pct;
  const double j_val = part.validation ? a.j_sim_pct : kNaN;
  progress.at(1.0, "done");
  return {{"j_est_pct", j_est}, {"j_val_pct", models::number_or_null(j_val)}, {"summary", report.summary}, {"plots", plots}};
}

}  // namespace

JobKind analyze_job() { return {"analyze", analyze_params, analyze_work}; }

}  // namespace panelbass::api

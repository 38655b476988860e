// One verb, two doors, for the verbs usecase_parity_test.cpp leaves out: design nn, measure (the excite job), verify,
// tune, design mirror, harmonics and identify oscillator. The CLI and the API's job run the same use case
// (usecases/), so given the same models, record and options they make the same model (or record) and the same
// figures, and refuse the same bad input with the same words. The CLI runs as a user runs it (the panelbass
// binary); the job through the job kinds' registry. Small settings throughout: each door's run is a second or so.
#include <gtest/gtest.h>

#include "dsp/data_file.h"
#include "dsp/excitation.h"
#include "models/control/mirror_filter.h"
#include "models/io/json_file.h"
#include "models/oscillator/oscillator_model.h"
#include "models/plant/plant_config.h"
#include "tests/api/jobs/job_test_fixture.h"
#include "tests/api/jobs/usecase_parity_fixture.h"
#include "tests/support/cli_runner.h"

namespace panelbass::api::job_testing {
namespace {

class UseCaseParityVerbs : public UseCaseParityTest {
 protected:
  // The backend: panel-exciter without its sensor noise, so that both doors' plays record the same samples whatever
  // noise seed each draws (the CLI's --quiet-sensor); the plant known to jobs.
  void use_quiet_exciter() {
    const models::PlantConfig plant = models::without_sensor_noise(models::plant_preset("panel-exciter"));
    env_.plant = plant;
    env_.excite = [plant](const Eigen::VectorXd& drive) { return Eigen::VectorXd(models::simulate(plant, drive, 1).y); };
  }

  // Stored model `id` written as `name` in the test's folder.
  void write_model(const std::string& id, const std::string& name) { models::write_json_file(dir_ / name, *store_->model(id)); }

  // The refusal of `kind` with `params` and of `panelbass <args>`: the same words after "params.<field>: " and
  // "<flag>: ".
  void expect_same_refusal(const std::string& kind, const json& params, const std::string& args, const std::string& field,
                           const std::string& flag, const std::string& words) {
    const std::string job = refusal(kind, params);
    const testing_support::RunResult r = cli(args);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(job.find("params." + field + ": " + words), std::string::npos) << job;
    EXPECT_NE(r.err.find(flag + ": " + words), std::string::npos) << r.err;
  }
};

TEST_F(UseCaseParityVerbs, DesignNnTrainsTheSameControllerFromBothDoors) {
  const json ids = design_nn_models();
  write_model(ids.at("plant_model"), "narx.json");
  write_model(ids.at("feedforward_model"), "ff.json");
  // The defaults written once: the job's are the models' FeedbackDesignOptions, as the CLI's.
  const json defaults = validate_job_params("design-nn", ids, env_);
  const models::FeedbackDesignOptions design;
  EXPECT_EQ(defaults.at("samples"), design.samples);
  EXPECT_EQ(defaults.at("max_iterations"), design.training.max_iterations);
  EXPECT_EQ(defaults.at("hidden"), json(design.structure.hidden));
  EXPECT_EQ(defaults.at("sine_band"), json({design.sine_low_hz, design.sine_high_hz}));
  EXPECT_TRUE(defaults.at("band_pass").is_null()) << "the feedforward's own band-pass";

  json params = ids;
  params.update({{"samples", 2000}, {"max_iterations", 2}, {"hidden", {3}}, {"seed", 2}});
  const json job = run("design-nn", params, "j3");
  const testing_support::RunResult r =
      cli("design nn --plant narx.json --ff ff.json --samples 2000 --iterations 2 --hidden 3 --seed 2 --out fb.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const models::NeuralFeedback from_job = models::neural_feedback_from_json(*store_->model(job.at("model_id")));
  const models::NeuralFeedback from_cli = models::neural_feedback_from_json(models::read_json_file(dir_ / "fb.json"));
  ASSERT_EQ(from_cli.net.parameters().size(), from_job.net.parameters().size());
  EXPECT_LE((from_cli.net.parameters() - from_job.net.parameters()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ(from_cli.meta.at("bandpass"), from_job.meta.at("bandpass"));
  // The same figures: the job's summary is what the CLI prints, but for the models' names.
  const json printed = json::parse(r.out);
  EXPECT_EQ(without(job.at("summary"), {"plant_model", "feedforward_model"}),
            without(printed, {"plant_model", "feedforward_model", "out", "history"}));
  expect_same_refusal("design-nn", [&] { json p = ids; p["nu"] = 101; return p; }(),
                      "design nn --plant narx.json --ff ff.json --nu 101 --out bad.json", "nu", "--nu",
                      "must be an integer in [0, 100], got 101");
}

TEST_F(UseCaseParityVerbs, MeasureRecordsWhatTheExciteJobRecords) {
  use_quiet_exciter();
  const json job = run("excite", {{"signal", "multisine"}, {"samples", 2000}, {"validation_samples", 1000},
                                  {"amplitude", 0.4}, {"seed", 3}}, "j1");
  const testing_support::RunResult r = cli("measure --backend virtual --plant panel-exciter --quiet-sensor --signal multisine "
                                           "--samples 2000 --validation-samples 1000 --amplitude 0.4 --seed 3 "
                                           "--out est.csv --val-out val.csv");
  ASSERT_EQ(r.status, 0) << r.err;
  const json printed = json::parse(r.out);
  // The same drive, played through the same transducer: the same record, to the 17 digits a CSV keeps.
  const dsp::Record est = dsp::read_data_file(dir_ / "est.csv", {"u", "y", "l"}, kFs);
  const dsp::Record val = dsp::read_data_file(dir_ / "val.csv", {"u", "y", "l"}, kFs);
  const json& record = job.at("record");
  for (const auto& [part, file] : {std::pair{"est", &est}, std::pair{"val", &val}}) {
    for (const char* column : {"u", "y", "l"}) {
      const Eigen::VectorXd from_job = samples_of(record.at(std::string(column) + "_" + part));
      const Eigen::VectorXd& from_cli = file->column(column);
      ASSERT_EQ(from_cli.size(), from_job.size()) << part << " " << column;
      EXPECT_LE((from_cli - from_job).cwiseAbs().maxCoeff(), 1e-15 * std::max(1.0, from_job.cwiseAbs().maxCoeff()))
          << part << " " << column;
    }
  }
  EXPECT_EQ(est.column("u").size(), 2000);
  EXPECT_EQ(val.column("u").size(), 1000);
  // The same figures.
  EXPECT_EQ(without(job, {"plots", "record"}), without(printed, {"backend", "plant", "out", "val_out"}));
  // The same refusals in the same words.
  expect_same_refusal("excite", {{"validation_samples", 100}},
                      "measure --validation-samples 100 --out est.csv --val-out val.csv", "validation_samples",
                      "--validation-samples", "must be 0 (none) or at least 200, got 100");
  const std::string lq = run("design-lq", {{"plant_model", store_reference_model()}}, "j2").at("model_id");
  expect_same_refusal("excite", {{"signal", "control"}, {"samples", 500}, {"feedforward_model", lq}},
                      "measure --signal control --samples 500 --validation-samples 0 --out est.csv", "samples", "--samples",
                      "a control excitation needs at least 1000 samples, got 500");
}

TEST_F(UseCaseParityVerbs, VerifyGivesTheSamePointsFromBothDoors) {
  use_quiet_exciter();
  const std::string lq = run("design-lq", {{"plant_model", store_reference_model()}}, "j1").at("model_id");
  write_model(lq, "ff.json");
  const json job = run("verify", {{"feedforward_model", lq}, {"frequencies", {80}}, {"levels", {0.2}},
                                  {"settle_seconds", 0.1}, {"analysis_seconds", 0.2}, {"max_plays", 2}}, "j2");
  const testing_support::RunResult r = cli("verify --ff ff.json --backend virtual --plant panel-exciter --quiet-sensor "
                                           "--probes 80 --levels 0.2 --settle-seconds 0.1 --analysis-seconds 0.2 --max-plays 2");
  ASSERT_EQ(r.status, 0) << r.err;
  const json printed = json::parse(r.out);
  ASSERT_EQ(job.at("points").size(), 1u);
  EXPECT_GT(job.at("points").at(0).at("chain").at("thd_pct").get<double>(), 0.0);
  // The same chain (the LQ feedforward behind the band-pass it was designed for) through the same transducer.
  EXPECT_EQ(without(job, {"plots", "backend"}), without(printed, {"backend", "plant"}));
  // The default program level is the request's, below the backend's safe level.
  EXPECT_EQ(validate_job_params("verify", {{"feedforward_model", lq}}, env_).at("levels"), json({0.2}));
  expect_same_refusal("verify", {{"feedforward_model", lq}, {"frequencies", {1000}}},
                      "verify --ff ff.json --probes 1000", "frequencies", "--probes",
                      "1000 Hz is outside [10, fs/4 = 750] Hz (its third harmonic must stay below fs/2)");
  // A plant model is no feedforward: both doors say which slot takes what.
  write_model(store_reference_model(), "lin.json");
  const testing_support::RunResult wrong = cli("verify --ff lin.json --probes 80");
  EXPECT_EQ(wrong.status, 1) << wrong.err;
  EXPECT_NE(wrong.err.find("lin.json: "), std::string::npos) << wrong.err;
  EXPECT_NE(wrong.err.find("feedforward slot takes"), std::string::npos) << wrong.err;
}

TEST_F(UseCaseParityVerbs, TuneMakesTheSameFilterAndDecisionFromBothDoors) {
  use_plant("panel-exciter");  // with its sensor noise: both doors draw the same noise seeds (seed + 1000, + 1001, …)
  const json params = {{"samples", 6000}, {"frequencies", {80}}, {"levels", {0.2}}, {"settle_seconds", 0.1},
                       {"analysis_seconds", 0.2}, {"max_plays", 2}, {"refine_friction", false}};
  const json job = run("tune", params, "j1");
  const testing_support::RunResult r = cli("tune --plant panel-exciter --samples 6000 --probes 80 --levels 0.2 "
                                           "--settle-seconds 0.1 --analysis-seconds 0.2 --max-plays 2 --no-refine "
                                           "--out mirror.json");
  ASSERT_TRUE(r.status == 0 || r.status == 1) << r.err;  // 1: left out, which the job says as well
  const json printed = json::parse(r.out.empty() ? "{}" : r.out);
  const models::MirrorModel from_job = models::mirror_model_from_json(*store_->model(job.at("mirror_model_id")));
  EXPECT_EQ(job.at("keep").get<bool>(), r.status == 0) << job.at("decision");
  if (r.status == 0) {
    const models::MirrorModel from_cli = models::mirror_model_from_json(models::read_json_file(dir_ / "mirror.json"));
    EXPECT_EQ(models::mirror_model_to_json(from_cli, {}).at("params"), models::mirror_model_to_json(from_job, {}).at("params"));
    EXPECT_EQ(printed.at("decision"), job.at("decision"));
    EXPECT_EQ(printed.at("summary"), job.at("summary"));
    EXPECT_EQ(printed.at("verify"), job.at("verify"));
    ASSERT_EQ(printed.at("steps").size(), job.at("steps").size());
    for (std::size_t k = 0; k < job.at("steps").size(); ++k) {
      EXPECT_EQ(printed.at("steps").at(k).at("summary"), job.at("steps").at(k).at("summary")) << k;
    }
  }
  expect_same_refusal("tune", {{"samples", 10}}, "tune --samples 10", "samples", "--samples",
                      "must be within 3000..1000000, got 10");
  expect_same_refusal("tune", {{"amplitude", 1.5}}, "tune --amplitude 1.5", "amplitude", "--amplitude",
                      "must be within (0, safe level 1], got 1.5");
}

TEST_F(UseCaseParityVerbs, DesignMirrorFitsTheSameFilterFromBothDoors) {
  use_quiet_exciter();
  const json job = run("design-mirror", {{"samples", 6000}, {"seed", 2}}, "j1");
  // The job's record: its multisine (f_min 10, f_max 300 Hz, peak 0.5) played into the plant, written for the CLI.
  dsp::MultisineSpec spec;
  spec.period = 6000;
  spec.fs = kFs;
  spec.f_min = 10.0;
  spec.f_max = 300.0;
  spec.amplitude = 0.5;
  spec.seed = 2;
  const Eigen::VectorXd drive = dsp::multisine(spec).signal;
  const models::PlantRecord played = models::simulate(*env_.plant, drive, 2);
  dsp::Record record;
  record.fs = kFs;
  record.add("u", drive);
  record.add("i", played.i);
  record.add("x", played.x);
  dsp::write_data_file(dir_ / "rec.csv", record);
  const testing_support::RunResult r = cli("design mirror --data rec.csv --fs 3000 --out mirror.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const models::MirrorModel from_job = models::mirror_model_from_json(*store_->model(job.at("model_id")));
  const models::MirrorModel from_cli = models::mirror_model_from_json(models::read_json_file(dir_ / "mirror.json"));
  const json a = models::mirror_model_to_json(from_job, {}).at("params"), b = models::mirror_model_to_json(from_cli, {}).at("params");
  // The CSV keeps 17 significant digits: the same record, so the same fit to rounding.
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [key, value] : a.items()) {
    if (value.is_number()) EXPECT_NEAR(b.at(key).get<double>(), value.get<double>(), 1e-9 * std::max(1.0, std::abs(value.get<double>()))) << key;
  }
  const json printed = json::parse(r.out);
  for (const auto& [key, value] : job.at("summary").items()) {
    if (value.is_number_float() && printed.contains(key)) {
      EXPECT_NEAR(printed.at(key).get<double>(), value.get<double>(), 1e-6 * std::max(1.0, std::abs(value.get<double>()))) << key;
    }
  }
  expect_same_refusal("design-mirror", {{"max_delay", 65}}, "design mirror --data rec.csv --fs 3000 --max-delay 65 --out bad.json",
                      "max_delay", "--max-delay", "must be within 0..64, got 65");
}

TEST_F(UseCaseParityVerbs, HarmonicsGivesTheSameLevelsFromBothDoors) {
  use_quiet_exciter();
  const std::string lin = store_reference_model();
  write_model(lin, "lin.json");
  const json job = run("harmonics", {{"model", lin}, {"frequencies", {80, 160}}, {"amplitudes", {0.5}}}, "j1");
  const testing_support::RunResult r = cli("harmonics --plant panel-exciter --model lin.json --freqs 80,160 --amplitudes 0.5");
  ASSERT_EQ(r.status, 0) << r.err;
  // The same stepped sine through the same plant (its sensor noise left out by default at both doors) and model.
  const json printed = json::parse(r.out);
  const std::vector<std::string> names = {"plant", "model", "source", "model_name"};
  EXPECT_EQ(without(job.at("summary"), names), without(printed, names));
  expect_same_refusal("harmonics", {{"measure", 10}}, "harmonics --measure 10", "measure", "--measure",
                      "must be within 16..10000000, got 10");
}

TEST_F(UseCaseParityVerbs, IdentifyOscillatorFitsTheSameModelFromBothDoors) {
  const json record = run("excite", {{"samples", 2000}, {"validation_samples", 1000}, {"amplitude", 0.5}, {"seed", 3}}, "j2");
  for (const char* part : {"est", "val"}) {
    dsp::Record r;
    r.fs = kFs;
    r.add("u", samples_of(record.at("record").at(std::string("u_") + part)));
    r.add("y", samples_of(record.at("record").at(std::string("y_") + part)));
    dsp::write_data_file(dir_ / (std::string(part) + ".csv"), r);
  }
  const json job = run("identify-oscillator", {{"record", "j2"}, {"max_iterations", 5}}, "j3");
  const testing_support::RunResult r = cli("identify oscillator --data est.csv --val val.csv --fs 3000 --max-iter 5 --out osc.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const json printed = json::parse(r.out);
  const json from_job = *store_->model(job.at("model_id"));
  const json from_cli = models::read_json_file(dir_ / "osc.json");
  EXPECT_EQ(from_cli.at("params"), from_job.at("params"));
  const std::vector<std::string> door_only = {"seconds", "out", "warnings", "data", "val"};
  json from_job_summary = without(job.at("summary"), door_only), from_cli_summary = without(printed, door_only);
  for (json* summary : {&from_job_summary, &from_cli_summary}) {
    for (json& stage : summary->at("stages")) stage.erase("seconds");  // how long each took
  }
  EXPECT_EQ(from_job_summary, from_cli_summary);
  expect_same_refusal("identify-oscillator", {{"record", "j2"}, {"substeps", 0}},
                      "identify oscillator --data est.csv --fs 3000 --substeps 0 --out bad.json", "substeps", "--substeps",
                      "must be within 1..64, got 0");
}

}  // namespace
}  // namespace panelbass::api::job_testing

// One verb, two doors: the CLI and the API's job run the same use case (usecases/), so given the same model (or
// record) and the same options they make the same model and the same figures, and refuse the same bad input with the
// same words: design lq, validate, identify ss, identify average, identify mimo, identify narx's restarts and plant
// survey.
// The CLI runs as a user runs it (the panelbass binary); the job through the job kinds' registry.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>

#include "dsp/data_file.h"
#include "models/io/json_file.h"
#include "tests/api/jobs/usecase_parity_fixture.h"
#include "api/record_store.h"
#include "dsp/periodic_record.h"
#include "models/linear/mimo_model.h"
#include "models/narx/narx_model.h"
#include "models/state_space_nn/ss_model.h"
#include "usecases/design_lq.h"

namespace panelbass::api::job_testing {
namespace {

class UseCaseParity : public UseCaseParityTest {
 protected:
  // Stores the reference model and writes the same file as lin.json; returns its id.
  std::string reference_model_in_both() {
    const std::string id = store_reference_model();
    models::write_json_file(dir_ / "lin.json", *store_->model(id));
    return id;
  }
};

TEST_F(UseCaseParity, DesignLqWithNoOptionsMakesTheSameControllerFromBothDoors) {
  const std::string id = reference_model_in_both();
  const json job = run("design-lq", {{"plant_model", id}}, "j1");
  const models::LqFeedforward from_job = models::lq_feedforward_from_json(*store_->model(job.at("model_id")));

  const testing_support::RunResult r = cli("design lq --model lin.json --out ff.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const json printed = json::parse(r.out);
  const models::LqFeedforward from_cli = models::lq_feedforward_from_json(models::read_json_file(dir_ / "ff.json"));

  // The defaults written once: models::LqWeights's R = 3 and R0 = 20 at both doors.
  EXPECT_EQ(from_job.weights.R, models::LqWeights{}.R);
  EXPECT_EQ(from_job.weights.R0, models::LqWeights{}.R0);
  EXPECT_EQ(from_cli.weights.R, from_job.weights.R);
  EXPECT_EQ(from_cli.weights.R0, from_job.weights.R0);
  ASSERT_EQ(from_cli.L.size(), from_job.L.size());
  EXPECT_LE((from_cli.L - from_job.L).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ(from_cli.meta.at("max_input"), from_job.meta.at("max_input"));
  EXPECT_EQ(from_cli.meta.at("bandpass"), from_job.meta.at("bandpass"));
  // The same figures: the job's summary is what the CLI prints (but where each door keeps the controller).
  json summary = job.at("summary"), result = printed;
  for (json* j : {&summary, &result}) {
    for (const char* door_only : {"plant_model", "out", "plots"}) j->erase(door_only);
  }
  EXPECT_EQ(summary, result);
}

TEST_F(UseCaseParity, DesignLqRefusesTheSameBadInputWithTheSameWordsAtBothDoors) {
  const std::string id = reference_model_in_both();
  const std::string job = refusal("design-lq", {{"plant_model", id}, {"r0", -1}});
  const testing_support::RunResult r = cli("design lq --model lin.json --R0 -1 --out ff.json");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(job.find("params.r0: must be ≥ 0, got -1"), std::string::npos) << job;
  EXPECT_NE(r.err.find("--R0: must be ≥ 0, got -1"), std::string::npos) << r.err;

  const std::string both = refusal("design-lq", {{"plant_model", id}, {"r", 1.0}, {"max_input", 0.3}});
  EXPECT_NE(both.find("params.max_input: choose the weight by r or by max_input, not both"), std::string::npos) << both;
  const std::string too_high = refusal("design-lq", {{"plant_model", id}, {"band_pass", {{"high_hz", 1600}}}});
  const testing_support::RunResult high = cli("design lq --model lin.json --bandpass 20,1600 --out ff.json");
  EXPECT_NE(too_high.find("params.band_pass.high_hz: 1600 Hz is not below the model's Nyquist frequency 1500 Hz"),
            std::string::npos)
      << too_high;
  EXPECT_NE(high.err.find("--bandpass: 1600 Hz is not below the model's Nyquist frequency 1500 Hz"), std::string::npos)
      << high.err;
}

TEST_F(UseCaseParity, ValidateGivesTheSameJFromBothDoors) {
  const std::string id = reference_model_in_both();
  const json record = run("excite", {{"samples", 2000}, {"validation_samples", 1000}, {"amplitude", 0.5}, {"seed", 3}}, "j2");
  const json job = run("validate", {{"model", id}, {"record", "j2"}, {"init", 10}}, "j3");

  dsp::Record val;
  val.fs = kFs;
  val.add("u", samples_of(record.at("record").at("u_val")));
  val.add("y", samples_of(record.at("record").at("y_val")));
  dsp::write_data_file(dir_ / "val.csv", val);
  const testing_support::RunResult r = cli("validate --model lin.json --data val.csv --fs 3000 --init 10");
  ASSERT_EQ(r.status, 0) << r.err;
  const json printed = json::parse(r.out);
  // CSV keeps 17 significant digits: the same record, so the same J to rounding.
  EXPECT_NEAR(printed.at("J_sim_pct").get<double>(), job.at("j_val_pct").get<double>(), 1e-9);
  EXPECT_NEAR(printed.at("J_sim_pct").get<double>(), job.at("summary").at("J_sim_pct").get<double>(), 1e-9);
  EXPECT_NEAR(printed.at("J_pred_pct").get<double>(), job.at("summary").at("J_pred_pct").get<double>(), 1e-9);
  EXPECT_EQ(printed.at("samples"), job.at("summary").at("samples"));
  // An init as long as the record: refused by both doors with the same words.
  const std::string refused = one_line_error<std::invalid_argument>([&] {
    run("validate", {{"model", id}, {"record", "j2"}, {"init", 1000}}, "j4");
  });
  const testing_support::RunResult cli_refused = cli("validate --model lin.json --data val.csv --fs 3000 --init 1000");
  EXPECT_NE(refused.find("params.init: 1000 is not shorter than the data (1000 samples)"), std::string::npos) << refused;
  EXPECT_NE(cli_refused.err.find("--init: 1000 is not shorter than the data (1000 samples)"), std::string::npos)
      << cli_refused.err;
}

// An excite job's two parts written as est.csv and val.csv (u, y at 3000 Hz) for the CLI: the same record at both
// doors (CSV keeps 17 significant digits, so the same doubles).
void write_parts(const json& excite_result, const std::filesystem::path& dir) {
  for (const char* part : {"est", "val"}) {
    dsp::Record r;
    r.fs = kFs;
    r.add("u", samples_of(excite_result.at("record").at(std::string("u_") + part)));
    r.add("y", samples_of(excite_result.at("record").at(std::string("y_") + part)));
    dsp::write_data_file(dir / (std::string(part) + ".csv"), r);
  }
}

// A summary without what only one door has (where the model went, how long it took).
json comparable(json summary) {
  for (const char* door_only : {"out", "history_out", "seconds"}) summary.erase(door_only);
  return summary;
}

// The small ss training both doors run in these tests, as flags and as params.
const char* const kSmallSsFlags = "--nx 2 --hidden 3 --lags 8 --window 40 --epochs 2 --seed 2";
json small_ss_params(const std::string& record, int seed) {
  return {{"record", record}, {"nx", 2}, {"hidden", 3}, {"lags", 8}, {"window", 40}, {"epochs", 2}, {"seed", seed}};
}

TEST_F(UseCaseParity, IdentifySsMakesTheSameModelFromBothDoors) {
  const json record = run("excite", {{"samples", 2000}, {"validation_samples", 1000}, {"amplitude", 0.5}, {"seed", 3}}, "j2");
  write_parts(record, dir_);
  const json job = run("identify-ss", small_ss_params("j2", 2), "j3");
  const testing_support::RunResult r =
      cli(std::string("identify ss --data est.csv --val val.csv --fs 3000 ") + kSmallSsFlags + " --out ss.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const models::SsModel from_cli = models::ss_model_from_json(models::read_json_file(dir_ / "ss.json"));
  const models::SsModel from_job = models::ss_model_from_json(*store_->model(job.at("model_id")));
  // The defaults written once (IdentifySsRequest): the same structure, the same trained weights.
  EXPECT_EQ(from_job.structure.states, 2);
  EXPECT_EQ(from_job.structure.lags, 8);
  ASSERT_EQ(from_cli.theta.size(), from_job.theta.size());
  EXPECT_LE((from_cli.theta - from_job.theta).cwiseAbs().maxCoeff(), 1e-9);
  // The same figures: the job's summary is what the CLI prints.
  const json printed = json::parse(r.out);
  EXPECT_EQ(comparable(job.at("summary")), comparable(printed));
  EXPECT_EQ(job.at("j_val_pct"), printed.at("J_val_pct"));
  // One bad field, the same words at both doors.
  const std::string refused = refusal("identify-ss", {{"record", "j2"}, {"epochs", -1}});
  const testing_support::RunResult bad = cli("identify ss --data est.csv --fs 3000 --epochs -1 --out bad.json");
  EXPECT_EQ(bad.status, 2) << bad.err;
  EXPECT_NE(refused.find("params.epochs: must be within 0..1000000, got -1"), std::string::npos) << refused;
  EXPECT_NE(bad.err.find("--epochs: must be within 0..1000000, got -1"), std::string::npos) << bad.err;
}

// A cancelled identify-ss job unwinds from inside the training and stores nothing.
TEST_F(UseCaseParity, ACancelledIdentifySsJobStoresNothing) {
  run("excite", {{"samples", 2000}, {"validation_samples", 1000}, {"amplitude", 0.5}, {"seed", 3}}, "j2");
  FakeControl control("j3", 4);
  json params = small_ss_params("j2", 2);
  params["epochs"] = 50;
  EXPECT_THROW(job_work("identify-ss", env_)(validate_job_params("identify-ss", params, env_), control), JobCancelled);
  EXPECT_EQ(control.reports.size(), 4u);
  EXPECT_TRUE(store_->list().empty()) << "a cancelled job stored a model";
}

TEST_F(UseCaseParity, IdentifyAverageMakesTheSameModelFromBothDoors) {
  const json record = run("excite", {{"samples", 2000}, {"validation_samples", 1000}, {"amplitude", 0.5}, {"seed", 3}}, "j2");
  write_parts(record, dir_);
  const std::string a = run("identify-ss", small_ss_params("j2", 2), "j3").at("model_id");
  const std::string b = run("identify-ss", small_ss_params("j2", 5), "j4").at("model_id");
  models::write_json_file(dir_ / "a.json", *store_->model(a));
  models::write_json_file(dir_ / "b.json", *store_->model(b));
  const json job = run("identify-average", {{"models", {a, b}}, {"record", "j2"}}, "j5");
  const testing_support::RunResult r = cli("identify average --models a.json b.json --val val.csv --fs 3000 --out avg.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const json printed = json::parse(r.out);
  const models::SsModel from_cli = models::ss_model_from_json(models::read_json_file(dir_ / "avg.json"));
  const models::SsModel from_job = models::ss_model_from_json(*store_->model(job.at("model_id")));
  ASSERT_EQ(from_cli.theta.size(), from_job.theta.size());
  EXPECT_LE((from_cli.theta - from_job.theta).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(job.at("summary").at("members").size(), printed.at("members").size());
  EXPECT_NEAR(job.at("j_val_pct").get<double>(), printed.at("J_val_pct").get<double>(), 1e-9);
  EXPECT_EQ(job.at("summary").at("states"), printed.at("states"));
  // Models trained on another record (another scaling) are refused before anything is queued, naming both.
  run("excite", {{"samples", 2000}, {"validation_samples", 0}, {"amplitude", 0.2}, {"seed", 9}}, "j6");
  const std::string c = run("identify-ss", small_ss_params("j6", 2), "j7").at("model_id");
  const std::string mixed = refusal("identify-average", {{"models", {a, c}}});
  EXPECT_NE(mixed.find("params.models: " + c + " cannot be averaged with " + a + ": it has another scaling"),
            std::string::npos)
      << mixed;
  const std::string refused = refusal("identify-average", {{"models", {a, b}}, {"init", -1}});
  const testing_support::RunResult bad = cli("identify average --models a.json b.json --init -1 --out bad.json");
  EXPECT_EQ(bad.status, 2) << bad.err;
  EXPECT_NE(refused.find("params.init: must be ≥ 0, got -1"), std::string::npos) << refused;
  EXPECT_NE(bad.err.find("--init: must be ≥ 0, got -1"), std::string::npos) << bad.err;
}

// A periodic record of two inputs and two outputs through two first-order sections (y1 from u1, y2 from u1 and
// u2), in steady state: `realizations` random-phase realisations of 2 periods of 100 samples, at 3000 Hz.
dsp::PeriodicRecord periodic_two_by_two(int realizations) {
  dsp::PeriodicRecord record;
  record.inputs = {"u1", "u2"};
  record.outputs = {"y1", "y2"};
  record.period = 100;
  record.fs = kFs;
  for (int r = 0; r < realizations; ++r) {
    const Eigen::MatrixXd u = Eigen::MatrixXd::NullaryExpr(100, 2, [r](Eigen::Index k, Eigen::Index j) {
      return std::sin(0.37 * static_cast<double>((r + 1) * (k + 1) * (j + 2))) * 0.5;
    });
    Eigen::Vector2d x = Eigen::Vector2d::Zero();
    Eigen::MatrixXd y(100, 2);
    for (int pass = 0; pass < 20; ++pass) {  // the transient of 0.8^k long gone by the last pass
      for (Eigen::Index k = 0; k < 100; ++k) {
        y(k, 0) = x(0);
        y(k, 1) = x(1);
        x = Eigen::Vector2d(0.8 * x(0) + u(k, 0), 0.5 * x(1) + 0.3 * u(k, 0) - 0.4 * u(k, 1));
      }
    }
    record.u.push_back({u, u});
    record.y.push_back({y, y});
  }
  return record;
}

TEST_F(UseCaseParity, IdentifyMimoMakesTheSameModelFromBothDoors) {
  RecordStore records(dir_ / "store");
  env_.records = &records;
  dsp::write_periodic_csv(dir_ / "train.csv", periodic_two_by_two(3));
  RecordUpload upload;
  upload.content_type = "text/csv";
  upload.fs = kFs;
  upload.input = "u1";
  upload.output = "y1";
  const std::string id = records.put(text_of(dir_ / "train.csv"), upload, "periodic", kFs).id;
  const json params = {{"record", id}, {"inputs", {"u1", "u2"}}, {"outputs", {"y1", "y2"}}, {"order", 2}, {"taps", 40},
                       {"max_iterations", 10}};
  const json job = run("identify-mimo", params, "j2");
  const testing_support::RunResult r = cli("identify mimo --data train.csv --fs 3000 --inputs u1,u2 --outputs y1,y2 "
                                           "--order 2 --taps 40 --max-iter 10 --out m.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const json printed = json::parse(r.out);
  const models::MimoModel from_cli = models::mimo_model_from_json(models::read_json_file(dir_ / "m.json"));
  const models::MimoModel from_job = models::mimo_model_from_json(job.at("model"));
  ASSERT_EQ(from_cli.ss.A.rows(), 2);
  EXPECT_LE((from_cli.ss.A - from_job.ss.A).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((from_cli.ss.C - from_job.ss.C).cwiseAbs().maxCoeff(), 1e-12);
  // The same figures but the record's name (the file, the uploaded record).
  json summary = comparable(job.at("summary")), result = comparable(printed);
  summary.erase("records");
  result.erase("records");
  EXPECT_EQ(summary, result);
  EXPECT_LT(job.at("j_val_pct").get<double>(), 1e-6) << "noise-free data of an order-2 system";
  const std::string refused = refusal("identify-mimo", {{"record", id}, {"inputs", {"u1", "u2"}}, {"outputs", {"y1", "y2"}},
                                                        {"order", 201}});
  const testing_support::RunResult bad = cli("identify mimo --data train.csv --fs 3000 --inputs u1,u2 --outputs y1,y2 "
                                             "--order 201 --out bad.json");
  EXPECT_EQ(bad.status, 2) << bad.err;
  EXPECT_NE(refused.find("params.order: must be within 0..200, got 201"), std::string::npos) << refused;
  EXPECT_NE(bad.err.find("--order: must be within 0..200, got 201"), std::string::npos) << bad.err;
  // A column the record lacks is named by both.
  const std::string missing = refusal("identify-mimo", {{"record", id}, {"inputs", {"u1", "u3"}}, {"outputs", {"y1", "y2"}}});
  EXPECT_NE(missing.find("params.record: "), std::string::npos) << missing;
  EXPECT_NE(missing.find("no column \"u3\""), std::string::npos) << missing;
}

// identify narx --restarts and the identify-narx job's restarts: one use case (usecases/narx_restarts.h), so the same
// record, structure and seed give the same trainings, the same one kept and the same model.
TEST_F(UseCaseParity, IdentifyNarxRestartsKeepTheSameModelFromBothDoors) {
  const json record = run("excite", {{"samples", 2000}, {"validation_samples", 1000}, {"amplitude", 0.5}, {"seed", 3}}, "j2");
  write_parts(record, dir_);
  const json job = run("identify-narx", {{"record", "j2"}, {"na", 2}, {"nb", 2}, {"nk", 1}, {"hidden", {3}},
                                         {"max_iterations", 3}, {"seed", 4}, {"restarts", 3}}, "j3");
  const testing_support::RunResult r = cli("identify narx --data est.csv --val val.csv --fs 3000 --na 2 --nb 2 --nk 1 "
                                           "--hidden 3 --max-iter 3 --seed 4 --restarts 3 --out narx.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const json printed = json::parse(r.out);
  const json& from_job_restarts = job.at("summary").at("restarts");
  const json& from_cli_restarts = printed.at("structure").at("restarts");
  // The same three trainings, from seeds 4, 5, 6, with the same validation J each.
  ASSERT_EQ(from_job_restarts.at("tried").size(), 3u) << from_job_restarts;
  ASSERT_EQ(from_cli_restarts.at("tried").size(), 3u) << from_cli_restarts;
  double lowest = 1e300;
  std::uint64_t lowest_seed = 0;
  for (std::size_t k = 0; k < 3; ++k) {
    const json &a = from_job_restarts.at("tried")[k], &b = from_cli_restarts.at("tried")[k];
    EXPECT_EQ(a.at("seed"), 4 + k);
    EXPECT_EQ(b.at("seed"), 4 + k);
    EXPECT_NEAR(a.at("J_val_pct").get<double>(), b.at("J_val_pct").get<double>(), 1e-9 * b.at("J_val_pct").get<double>());
    if (a.at("J_val_pct").get<double>() < lowest) {
      lowest = a.at("J_val_pct").get<double>();
      lowest_seed = a.at("seed").get<std::uint64_t>();
    }
  }
  EXPECT_NE(from_job_restarts.at("tried")[0].at("J_val_pct"), from_job_restarts.at("tried")[1].at("J_val_pct"))
      << "restarts start from different weights";
  // The one of the lowest validation J kept, at both doors: the same weights, the same J.
  EXPECT_EQ(from_job_restarts.at("chosen_seed"), lowest_seed);
  EXPECT_EQ(from_cli_restarts.at("chosen_seed"), lowest_seed);
  const models::NarxModel from_cli = models::narx_model_from_json(models::read_json_file(dir_ / "narx.json"));
  const models::NarxModel from_job = models::narx_model_from_json(*store_->model(job.at("model_id")));
  EXPECT_EQ(from_job.meta.at("seed"), lowest_seed);
  EXPECT_EQ(from_cli.meta.at("seed"), lowest_seed);
  ASSERT_EQ(from_cli.net.parameters().size(), from_job.net.parameters().size());
  EXPECT_LE((from_cli.net.parameters() - from_job.net.parameters()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(job.at("j_val_pct").get<double>(), printed.at("J_val_pct").get<double>(), 1e-9 * lowest);
  EXPECT_NEAR(job.at("j_val_pct").get<double>(), lowest, 1e-9 * lowest);
  EXPECT_EQ(job.at("summary").at("iterations"), printed.at("iterations"));

  // Refused with the same words: no validation part to choose by, or a start that is not a seed's draw.
  const std::string no_val = refusal("identify-narx", {{"excite", {{"validation_samples", 0}}}, {"restarts", 2}});
  const testing_support::RunResult cli_no_val = cli("identify narx --data est.csv --fs 3000 --restarts 2 --out no.json");
  EXPECT_EQ(cli_no_val.status, 2) << cli_no_val.err;
  const std::string words = "2 trainings need validation data: the one of the lowest validation J is kept";
  EXPECT_NE(no_val.find("params.restarts: " + words), std::string::npos) << no_val;
  EXPECT_NE(cli_no_val.err.find("--restarts: " + words), std::string::npos) << cli_no_val.err;
  const std::string seeded = refusal("identify-narx", {{"record", "j2"}, {"friction_units", {3.0}}, {"restarts", 2}});
  const testing_support::RunResult cli_seeded =
      cli("identify narx --data est.csv --val val.csv --fs 3000 --friction-units 3 --restarts 2 --out no.json");
  const std::string fresh = "2 trainings start from their seeds' weights";
  EXPECT_NE(seeded.find("params.restarts: " + fresh), std::string::npos) << seeded;
  EXPECT_NE(cli_seeded.err.find("--restarts: " + fresh), std::string::npos) << cli_seeded.err;
}

TEST_F(UseCaseParity, PlantSurveyGivesTheSameFiguresFromBothDoors) {
  const json job = run("plant-survey", {{"plant", "panel-exciter"}, {"samples", 2000}, {"seed", 3}}, "j1");
  const testing_support::RunResult r = cli("plant survey panel-exciter --samples 2000 --seed 3");
  ASSERT_EQ(r.status, 0) << r.err;
  // The same simulation from the same seed: the same figures, to the last digit the JSON keeps.
  EXPECT_EQ(job.at("summary"), json::parse(r.out));
  EXPECT_EQ(job.at("summary").at("plant"), "panel-exciter");
  // The default plant is the server's own transducer when it runs one, else the first preset.
  EXPECT_EQ(validate_job_params("plant-survey", json::object(), env_).at("plant"), models::plant_preset_names().front());
  use_plant("linear");
  EXPECT_EQ(validate_job_params("plant-survey", json::object(), env_).at("plant"), "server");
  // A field out of range, the same words at both doors.
  const std::string refused = refusal("plant-survey", {{"plant", "panel-exciter"}, {"samples", 10}});
  const testing_support::RunResult bad = cli("plant survey panel-exciter --samples 10");
  EXPECT_EQ(bad.status, 2) << bad.err;
  EXPECT_NE(refused.find("params.samples: must be within 1000..10000000, got 10"), std::string::npos) << refused;
  EXPECT_NE(bad.err.find("--samples: must be within 1000..10000000, got 10"), std::string::npos) << bad.err;
  const std::string loud = refusal("plant-survey", {{"amplitude", 1.5}});
  const testing_support::RunResult bad_loud = cli("plant survey panel-exciter --amplitude 1.5");
  EXPECT_NE(loud.find("params.amplitude: must be within (0, 1], got 1.5"), std::string::npos) << loud;
  EXPECT_NE(bad_loud.err.find("--amplitude: must be within (0, 1], got 1.5"), std::string::npos) << bad_loud.err;
}

}  // namespace
}  // namespace panelbass::api::job_testing

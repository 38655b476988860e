// The job kinds of ROUTES.md "Jobs": params validation (named fields, defaults), and each kind's work
// against a fake environment whose backend is an independent reference — a second-order system written
// as its textbook difference equation (tests/support/linear_systems.h), or the virtual transducer.

#include "api/jobs/job_kinds.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <map>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "api/model_store.h"
#include "api/jobs/excitation_record.h"
#include "api/model_validation.h"
#include "api/jobs/job_plots.h"
#include "engine/chain_evaluation.h"
#include "engine/chain_file.h"
#include "engine/distortion_attribution.h"
#include "engine/evaluation_json.h"
#include "models/linear/linear_model.h"
#include "models/control/feedback_design.h"
#include "models/control/lq_feedforward.h"
#include "models/kinds/model_file.h"
#include "models/narx/narx_training.h"
#include "dsp/butterworth.h"
#include "models/control/neural_feedback.h"
#include "models/plant/plant_presets.h"
#include "models/linear/state_space.h"
#include "models/plant/virtual_transducer.h"
#include "tests/support/expect_error.h"
#include "tests/support/linear_systems.h"
#include "tests/support/scratch_directory.h"

namespace panelbass::api {
namespace {

using nlohmann::json;
using testing_support::one_line_error;

// A progress report the fake control received.
struct Report {
  double fraction;
  std::string message;
};

// Records every progress report; throws JobCancelled on the report after `cancel_after` of them.
class FakeControl : public JobControl {
 public:
  explicit FakeControl(std::string id, int cancel_after = -1) : id_(std::move(id)), cancel_after_(cancel_after) {}
  void progress(double fraction, const std::string& message) override {
    if (cancel_after_ >= 0 && static_cast<int>(reports.size()) >= cancel_after_) {
      cancelled_ = true;
      throw JobCancelled{};
    }
    reports.push_back({fraction, message});
  }
  bool cancelled() const override { return cancelled_; }
  const std::string& job_id() const override { return id_; }

  std::vector<Report> reports;

 private:
  std::string id_;
  int cancel_after_;
  bool cancelled_ = false;
};

// The reference system: a resonance at 300 Hz (pole radius 0.9) with one sample of delay,
// y(k) = 2r·cos θ·y(k−1) − r²·y(k−2) + 0.3·u(k−1) + 0.2·u(k−2), at fs = 3000 Hz.
constexpr double kFs = 3000.0;
constexpr double kRadius = 0.9;
constexpr double kResonanceHz = 300.0;

models::TransferFunction reference_system() {
  const double theta = 2.0 * std::numbers::pi * kResonanceHz / kFs;
  models::TransferFunction tf;
  tf.a = Eigen::Vector2d(-2.0 * kRadius * std::cos(theta), kRadius * kRadius);
  tf.b = Eigen::Vector2d(0.3, 0.2);
  tf.nk = 1;
  return tf;
}

// Every number in `value` finite (no NaN or infinity left in a result).
bool finite_everywhere(const json& value) {
  if (value.is_number_float()) return std::isfinite(value.get<double>());
  if (value.is_array() || value.is_object()) {
    for (const json& v : value) {
      if (!finite_everywhere(v)) return false;
    }
  }
  return true;
}

// A plot: the named columns, all arrays of the same non-zero length, of finite numbers (or null where
// `nullable` allows).
void expect_plot(const json& plot, const std::vector<std::string>& columns, const std::vector<std::string>& nullable = {}) {
  ASSERT_TRUE(plot.is_object()) << plot.dump().substr(0, 200);
  ASSERT_EQ(plot.size(), columns.size()) << plot.dump().substr(0, 200);
  const std::size_t n = plot.at(columns.front()).size();
  EXPECT_GT(n, 0u);
  for (const std::string& c : columns) {
    ASSERT_TRUE(plot.contains(c)) << c;
    ASSERT_TRUE(plot.at(c).is_array()) << c;
    EXPECT_EQ(plot.at(c).size(), n) << c;
    const bool may_be_null = std::find(nullable.begin(), nullable.end(), c) != nullable.end();
    for (const json& v : plot.at(c)) {
      if (v.is_null() && may_be_null) continue;
      ASSERT_TRUE(v.is_number()) << c << ": " << v;
      ASSERT_TRUE(std::isfinite(v.get<double>())) << c;
    }
  }
}

// Progress reports rise (never fall) within [0, 1] and end at 1.
void expect_progress(const FakeControl& control) {
  ASSERT_FALSE(control.reports.empty());
  for (std::size_t k = 0; k < control.reports.size(); ++k) {
    EXPECT_GE(control.reports[k].fraction, 0.0);
    EXPECT_LE(control.reports[k].fraction, 1.0);
    if (k > 0) {
      EXPECT_GE(control.reports[k].fraction, control.reports[k - 1].fraction) << control.reports[k].message;
    }
  }
  EXPECT_DOUBLE_EQ(control.reports.back().fraction, 1.0);
}

class JobKindsTest : public testing_support::ScratchDirectoryTest {
 protected:
  JobKindsTest() {
    store_ = std::make_unique<ModelStore>(dir_ / "store");
    env_.fs = kFs;
    env_.store = store_.get();
    // The backend: the reference system from rest, plus a little seeded measurement noise.
    env_.excite = [this](const Eigen::VectorXd& drive) {
      ++excitations_;
      max_drive_ = std::max(max_drive_, drive.cwiseAbs().maxCoeff());
      return Eigen::VectorXd(testing_support::simulate(reference_system(), drive) +
                             testing_support::gaussian(drive.size(), 1e-4, 100 + excitations_));
    };
    env_.job_result = [this](const std::string& id) -> std::optional<json> {
      const auto it = results_.find(id);
      if (it == results_.end()) return std::nullopt;
      return it->second;
    };
  }

  // Backend: the virtual transducer `name` (a fresh plant per excitation), and the plant known to jobs.
  void use_plant(const std::string& name) {
    const models::PlantConfig plant = models::plant_preset(name);
    env_.plant = plant;
    env_.excite = [this, plant](const Eigen::VectorXd& drive) {
      ++excitations_;
      return Eigen::VectorXd(models::simulate(plant, drive, 7 + excitations_).y);
    };
  }

  // Validates and runs `kind` as job `id`; keeps the result for later "record" params.
  json run(const std::string& kind, const json& params, const std::string& id) {
    FakeControl control(id);
    return run(kind, params, control);
  }

  json run(const std::string& kind, const json& params, FakeControl& control) {
    const json filled = validate_job_params(kind, params, env_);
    const json result = job_work(kind, env_)(filled, control);
    EXPECT_TRUE(finite_everywhere(result));
    EXPECT_EQ(json::parse(result.dump()), result);
    results_[control.job_id()] = result;
    return result;
  }

  // The message validate_job_params throws for `kind` and `params`.
  std::string refusal(const std::string& kind, const json& params) {
    return one_line_error<std::invalid_argument>([&] { validate_job_params(kind, params, env_); });
  }

  // Stores the reference system as a linear model file; returns its id.
  std::string store_reference_model() {
    models::LinearModel m;
    m.tf = reference_system();
    m.fs = kFs;
    m.method = "oe";
    const json file = models::linear_model_to_json(m);
    const ValidatedModel v = validate_model(file);
    return store_->put(file, v.kind, v.fs, "reference", "upload").id;
  }

  // The models a design-nn job needs, made by jobs j1 (an LQ controller of the reference system) and j2 (a
  // small NARX model of it): {"plant_model": narx, "feedforward_model": lq}.
  json design_nn_models() {
    const std::string lq = run("design-lq", {{"plant_model", store_reference_model()}, {"r", 3.0}}, "j1").at("model_id");
    const std::string narx = run("identify-narx",
                                 {{"excite", {{"samples", 2000}, {"validation_samples", 500}, {"amplitude", 0.5}}},
                                  {"na", 2}, {"nb", 2}, {"hidden", {3}}, {"max_iterations", 5}},
                                 "j2")
                                 .at("model_id");
    return {{"plant_model", narx}, {"feedforward_model", lq}};
  }

  std::unique_ptr<ModelStore> store_;
  JobEnvironment env_;
  std::map<std::string, json> results_;
  int excitations_ = 0;
  double max_drive_ = 0.0;
};

// ----- validation ------------------------------------------------------------------------------------

TEST(JobKinds, ListsTheKindsInTheOrderOfRoutes) {
  EXPECT_EQ(job_kinds(), (std::vector<std::string>{"excite", "identify-linear", "identify-narx", "design-lq", "design-nn",
                                                   "evaluate", "analyze", "diagnose"}));
}

TEST_F(JobKindsTest, UnknownKindIsRefusedWithTheKindsThereAre) {
  const std::string message = refusal("fly", json::object());
  EXPECT_NE(message.find("kind: unknown job kind \"fly\"; expected one of excite, identify-linear"), std::string::npos) << message;
  EXPECT_THROW(job_work("fly", env_), std::invalid_argument);
}

TEST_F(JobKindsTest, UnknownFieldIsNamedAtItsPath) {
  EXPECT_EQ(refusal("excite", {{"samples", 3000}, {"foo", 1}}), "params.foo: unknown field");
  EXPECT_EQ(refusal("identify-linear", {{"excite", {{"bar", true}}}}), "params.excite.bar: unknown field");
  EXPECT_EQ(refusal("design-lq", {{"plant_model", store_reference_model()}, {"band_pass", {{"q", 1}}}}),
            "params.band_pass.q: unknown field");
}

TEST_F(JobKindsTest, WrongTypesAndRangesAreNamed) {
  EXPECT_EQ(refusal("excite", {{"samples", "many"}}), "params.samples: must be an integer in [200, 10000000], got \"many\"");
  EXPECT_EQ(refusal("excite", {{"samples", 100}}), "params.samples: must be an integer in [200, 10000000], got 100");
  EXPECT_EQ(refusal("excite", {{"amplitude", 1.5}}), "params.amplitude: must be a number in (0, 1], got 1.5");
  EXPECT_EQ(refusal("excite", {{"amplitude", 0}}), "params.amplitude: must be a number in (0, 1], got 0");
  EXPECT_NE(refusal("excite", {{"signal", "chirp"}}).find("params.signal: must be one of \"noise\", \"multisine\""), std::string::npos);
  EXPECT_NE(refusal("excite", {{"validation_samples", 50}}).find("params.validation_samples"), std::string::npos);
  EXPECT_NE(refusal("identify-linear", {{"order", 41}}).find("params.order: must be an integer in [1, 40], got 41"), std::string::npos);
  EXPECT_NE(refusal("identify-linear", {{"order", 2.5}}).find("params.order"), std::string::npos);
  EXPECT_NE(refusal("identify-linear", {{"scan", {5, 2}}}).find("params.scan"), std::string::npos);
  EXPECT_NE(refusal("identify-linear", {{"scan", {2, 6}}, {"excite", {{"validation_samples", 0}}}}).find("params.scan: an order scan needs validation data"),
            std::string::npos);
  EXPECT_NE(refusal("identify-narx", {{"hidden", json::array()}}).find("params.hidden"), std::string::npos);
  EXPECT_NE(refusal("identify-narx", {{"hidden", {8, 0}}}).find("params.hidden[1]"), std::string::npos);
  EXPECT_NE(refusal("identify-narx", {{"modes", {"pem", "gradient"}}}).find("params.modes[1]"), std::string::npos);
  EXPECT_NE(refusal("identify-narx", {{"friction_units", {3.0, -1.0}}}).find("params.friction_units[1]"), std::string::npos);
  EXPECT_NE(refusal("identify-narx", {{"friction_units", {3.0, 10.0}}, {"friction_lags", 5}, {"hidden", {8}}})
                .find("params.friction_units: 2 gains x 5 lags"),
            std::string::npos);
  EXPECT_EQ(refusal("excite", json::array()), "params: expected an object, got array");
  EXPECT_NE(refusal("diagnose", {{"excite", {{"validation_samples", 0}}}}).find("params.excite.validation_samples"), std::string::npos);
}

TEST_F(JobKindsTest, DefaultsAreFilledIn) {
  const json excite = validate_job_params("excite", json::object(), env_);
  EXPECT_EQ(excite, (json{{"signal", "noise"}, {"samples", 10000}, {"validation_samples", 5000}, {"amplitude", 0.3}, {"seed", 1}}));
  // An integral float such as 1e4 is an integer.
  EXPECT_EQ(validate_job_params("excite", {{"samples", 1e4}}, env_).at("samples"), 10000);

  const json linear = validate_job_params("identify-linear", nullptr, env_);
  EXPECT_EQ(linear.at("excite"), excite);
  EXPECT_FALSE(linear.contains("record"));
  EXPECT_EQ(linear.at("method"), "oe");
  EXPECT_EQ(linear.at("order"), 8);
  EXPECT_EQ(linear.at("delay"), -1);
  EXPECT_TRUE(linear.at("scan").is_null());
  EXPECT_EQ(linear.at("max_iterations"), 100);

  const json narx = validate_job_params("identify-narx", json::object(), env_);
  EXPECT_EQ(narx.at("hidden"), json({8}));
  EXPECT_EQ(narx.at("modes"), json({"pem", "oem-d"}));
  EXPECT_EQ(narx.at("na"), 2);
  EXPECT_EQ(narx.at("nb"), 3);
  EXPECT_EQ(narx.at("friction_units"), json::array());
  EXPECT_EQ(narx.at("friction_lags"), 1);
  EXPECT_EQ(narx.at("weighted"), false);

  const json lq = validate_job_params("design-lq", {{"plant_model", store_reference_model()}}, env_);
  EXPECT_EQ(lq.at("r"), 1e-5);
  EXPECT_FALSE(lq.contains("max_input"));  // the weight is r unless a safe amplitude is asked for
  EXPECT_EQ(lq.at("band_pass"), (json{{"low_hz", 20.0}, {"high_hz", 1200.0}, {"order", 2}}));
}

TEST_F(JobKindsTest, DesignNnDefaultsComeFromTheDesignOptions) {
  const json models = design_nn_models();
  const json nn = validate_job_params("design-nn", models, env_);
  const models::FeedbackDesignOptions design;
  EXPECT_EQ(nn.at("nu"), design.structure.nu);
  EXPECT_EQ(nn.at("nv"), design.structure.nv);
  EXPECT_EQ(nn.at("ny"), design.structure.ny);
  EXPECT_EQ(nn.at("sine_share"), design.sine_share);
  EXPECT_EQ(nn.at("sine_peak"), design.sine_peak);
  EXPECT_EQ(nn.at("program_share"), design.program_share);
  EXPECT_EQ(nn.at("restarts"), 1);
  EXPECT_EQ(nn.at("desired"), "linear-model");
  EXPECT_EQ(nn.at("weighting"), "none");
  EXPECT_EQ(nn.at("keep"), "validation-jc");
  EXPECT_EQ(nn.at("probes_hz"), json({40.0, 80.0, 160.0, 320.0}));
  EXPECT_EQ(nn.at("rail_penalty"), design.training.rail_penalty);
  EXPECT_EQ(nn.at("dc_penalty"), design.training.dc_penalty);
  EXPECT_EQ(nn.at("samples"), 3000);
  EXPECT_EQ(nn.at("max_iterations"), 20);
  EXPECT_EQ(nn.at("hidden"), json({6}));
  EXPECT_EQ(nn.at("tune_on"), "none");
  EXPECT_EQ(nn.at("tune_playbacks"), design.device_playbacks);
  EXPECT_EQ(nn.at("start_from"), nullptr);
}

TEST_F(JobKindsTest, DesignNnRangesAreNamed) {
  const json models = design_nn_models();
  const auto with = [&](const json& extra) {
    json params = models;
    params.update(extra);
    return params;
  };
  const auto refused = [&](const json& extra) { return refusal("design-nn", with(extra)); };
  EXPECT_EQ(refused({{"nu", 101}}), "params.nu: must be an integer in [0, 100], got 101");
  EXPECT_EQ(refused({{"nv", -1}}), "params.nv: must be an integer in [0, 100], got -1");
  EXPECT_EQ(refused({{"ny", 2.5}}), "params.ny: must be an integer in [0, 100], got 2.5");
  EXPECT_EQ(refused({{"sine_share", 1.5}}), "params.sine_share: must be a number in [0, 1], got 1.5");
  EXPECT_EQ(refused({{"sine_peak", 0}}), "params.sine_peak: must be a number in (0, 1], got 0");
  EXPECT_EQ(refused({{"program_share", -0.1}}), "params.program_share: must be a number in [0, 1], got -0.1");
  EXPECT_EQ(refused({{"restarts", 0}}), "params.restarts: must be an integer in [1, 20], got 0");
  EXPECT_EQ(refused({{"restarts", 21}}), "params.restarts: must be an integer in [1, 20], got 21");
  EXPECT_EQ(refused({{"rail_penalty", -1}}), "params.rail_penalty: must be a number in [0, 1e+12], got -1");
  EXPECT_EQ(refused({{"rail_penalty", "high"}}), "params.rail_penalty: must be a number in [0, 1e+12], got \"high\"");
  EXPECT_EQ(refused({{"dc_penalty", -0.5}}), "params.dc_penalty: must be a number in [0, 1e+12], got -0.5");
  EXPECT_EQ(refused({{"restart", 2}}), "params.restart: unknown field");
  EXPECT_EQ(refused({{"keep", "best"}}).rfind("params.keep: ", 0), 0u);
  EXPECT_EQ(refused({{"desired", "flat"}}).rfind("params.desired: ", 0), 0u);
  EXPECT_EQ(refused({{"weighting", "both"}}).rfind("params.weighting: ", 0), 0u);
  EXPECT_EQ(refused({{"probes_hz", json::array()}}).rfind("params.probes_hz: ", 0), 0u);
  EXPECT_EQ(refused({{"tune_on", "table"}}).rfind("params.tune_on: ", 0), 0u);
  EXPECT_EQ(refused({{"tune_playbacks", 2}}),
            "params.tune_playbacks: plays each drive into the device of tune_on, and tune_on is \"none\"");
  EXPECT_EQ(refused({{"tune_playbacks", 65}}), "params.tune_playbacks: must be an integer in [1, 64], got 65");
  EXPECT_EQ(refused({{"tune_on", "linear"}}).rfind("params.tune_on: tuning on the device", 0), 0u) << "the target";
  EXPECT_EQ(refused({{"tune_on", "linear"}, {"desired", "plant-fundamental"}, {"weighting", "level"}})
                .rfind("params.tune_on: tuning on the device", 0),
            0u);
  const std::string narx = models.at("plant_model");
  EXPECT_EQ(refused({{"start_from", narx}}),
            "params.start_from: model " + narx + " is of kind \"narx\", expected neural_feedback");
  // The ends that belong to the ranges.
  const json ends = with({{"nu", 0}, {"nv", 100}, {"sine_share", 0}, {"sine_peak", 1}, {"program_share", 1}, {"restarts", 20},
                          {"rail_penalty", 0}, {"dc_penalty", 0}});
  EXPECT_NO_THROW(validate_job_params("design-nn", ends, env_));
}

TEST_F(JobKindsTest, ReferencedModelsMustExistWithTheRightKind) {
  EXPECT_EQ(refusal("design-lq", json::object()), "params.plant_model: required");
  EXPECT_EQ(refusal("design-lq", {{"plant_model", store_reference_model()}, {"r", 1.0}, {"max_input", 0.3}}),
            "params.max_input: choose the weight by r or by max_input, not both");
  for (const double bad : {0.0, 1.5}) {
    EXPECT_NE(refusal("design-lq", {{"plant_model", store_reference_model()}, {"max_input", bad}}).find("params.max_input"),
              std::string::npos)
        << bad;
  }
  EXPECT_EQ(refusal("design-lq", {{"plant_model", "m000000000000"}}), "params.plant_model: no stored model \"m000000000000\"");
  EXPECT_NE(refusal("design-lq", {{"plant_model", "../etc"}}).find("params.plant_model: must be an id"), std::string::npos);
  const std::string linear = store_reference_model();
  EXPECT_EQ(refusal("design-nn", {{"plant_model", linear}, {"feedforward_model", linear}}),
            "params.plant_model: model " + linear + " is of kind \"linear\", expected narx");
  EXPECT_EQ(refusal("analyze", json::object()), "params.model: required");
  EXPECT_NO_THROW(validate_job_params("diagnose", {{"baseline_model", linear}}, env_));
  EXPECT_NE(refusal("design-lq", {{"plant_model", linear}, {"band_pass", {{"high_hz", 1600}}}}).find("params.band_pass.high_hz"),
            std::string::npos);
}

TEST_F(JobKindsTest, RecordMustNameAFinishedExciteJob) {
  EXPECT_EQ(refusal("identify-linear", {{"record", "j99"}}),
            "params.record: no succeeded job \"j99\" (the record must name a finished excite job)");
  results_["j2"] = {{"model_id", "m0123456789ab"}};
  EXPECT_EQ(refusal("analyze", {{"model", store_reference_model()}, {"record", "j2"}}),
            "params.record: job j2 is not an excite job (its result has no \"record\")");
  results_["j3"] = {{"fs", kFs}, {"record", {{"u_est", {1.0, 2.0}}, {"y_est", {1.0}}, {"u_val", json::array()}, {"y_val", json::array()}}}};
  EXPECT_EQ(refusal("identify-narx", {{"record", "j3"}}),
            "params.record: job j3 has a record whose drive and response differ in length");
  EXPECT_EQ(refusal("identify-linear", {{"record", "j99"}, {"excite", json::object()}}),
            "params.record: give either \"record\" or \"excite\", not both");
  EXPECT_NE(refusal("identify-linear", {{"record", 3}}).find("params.record: expected the id of a finished excite job"), std::string::npos);
}

// ----- work --------------------------------------------------------------------------------------------

TEST_F(JobKindsTest, ExciteRecordsTheBackendsResponse) {
  FakeControl control("j1");
  const json result = run("excite", {{"samples", 3000}, {"validation_samples", 1000}, {"amplitude", 0.5}, {"seed", 4}}, control);
  expect_progress(control);
  EXPECT_EQ(excitations_, 2);
  EXPECT_LE(max_drive_, 0.5);
  EXPECT_EQ(result.at("samples"), 3000);
  EXPECT_EQ(result.at("validation_samples"), 1000);
  EXPECT_EQ(result.at("fs"), kFs);
  const json& record = result.at("record");
  ASSERT_EQ(record.at("u_est").size(), 3000u);
  ASSERT_EQ(record.at("y_val").size(), 1000u);
  // The response is the reference system's to this drive (within the added noise).
  Eigen::VectorXd u(3000), y(3000);
  for (int k = 0; k < 3000; ++k) {
    u[k] = record.at("u_est")[k].get<double>();
    y[k] = record.at("y_est")[k].get<double>();
  }
  EXPECT_LT((y - testing_support::simulate(reference_system(), u)).cwiseAbs().maxCoeff(), 1e-3);
  // Uniform noise in [−0.5, 0.5]: rms 0.5/√3.
  EXPECT_NEAR(result.at("rms_drive").get<double>(), 0.5 / std::sqrt(3.0), 0.01);
  expect_plot(result.at("plots").at("fit"), {"t", "drive", "measured"});
  EXPECT_EQ(result.at("plots").at("fit").at("t").size(), 2000u);
}

TEST_F(JobKindsTest, ExciteMultisineStaysWithinItsPeak) {
  const json result = run("excite", {{"signal", "multisine"}, {"samples", 5000}, {"validation_samples", 0}, {"amplitude", 0.8}}, "j1");
  EXPECT_LE(max_drive_, 0.8 + 1e-12);
  EXPECT_GT(max_drive_, 0.7);
  EXPECT_EQ(result.at("record").at("u_val").size(), 0u);
  EXPECT_EQ(excitations_, 1);
}

TEST_F(JobKindsTest, IdentifyLinearRecoversTheReferenceSystem) {
  run("excite", {{"samples", 3000}, {"validation_samples", 1000}, {"amplitude", 0.5}}, "j1");
  FakeControl control("j2");
  const json result = run("identify-linear", {{"record", "j1"}, {"method", "oe"}, {"order", 2}, {"max_iterations", 30}}, control);
  expect_progress(control);
  EXPECT_EQ(excitations_, 2) << "a record of its own was made although one was named";
  // The noise (σ = 1e-4 against an output rms near 0.5) leaves J far below 0.01 %.
  EXPECT_LT(result.at("j_est_pct").get<double>(), 0.01);
  EXPECT_LT(result.at("j_val_pct").get<double>(), 0.01);

  const std::string id = result.at("model_id").get<std::string>();
  const std::optional<StoredModel> stored = store_->find(id);
  ASSERT_TRUE(stored);
  EXPECT_EQ(stored->kind, "linear");
  EXPECT_EQ(stored->source, "j2");
  EXPECT_EQ(stored->name, "oe order 2 (j2)");
  const models::LinearModel model = models::linear_model_from_json(*store_->model(id));
  EXPECT_EQ(model.tf.nk, 1);
  // Poles: r·e^{±jθ} (scaling does not move poles); response in raw units at a few frequencies.
  const Eigen::VectorXcd poles = model.tf.poles();
  ASSERT_EQ(poles.size(), 2);
  for (Eigen::Index k = 0; k < 2; ++k) {
    EXPECT_NEAR(std::abs(poles[k]), kRadius, 1e-3);
    EXPECT_NEAR(std::abs(std::arg(poles[k])), 2.0 * std::numbers::pi * kResonanceHz / kFs, 1e-3);
  }
  for (double f : {50.0, 300.0, 900.0}) {
    const std::complex<double> h = model.tf.response(f, kFs) * model.scaling.y_scale / model.scaling.u_scale;
    const std::complex<double> truth = reference_system().response(f, kFs);
    EXPECT_LT(std::abs(h - truth) / std::abs(truth), 1e-2) << f << " Hz";
  }
  EXPECT_EQ(model.meta.at("J_est_pct"), result.at("j_est_pct"));

  const json& plots = result.at("plots");
  expect_plot(plots.at("fit"), {"t", "measured", "simulated"});
  EXPECT_EQ(plots.at("fit").at("t").size(), 950u);  // the validation part after the 50 initial samples
  expect_plot(plots.at("spectrum"), {"f", "measured_db", "model_db"});
  expect_plot(plots.at("history"), {"iteration", "j_est_pct", "j_val_pct"}, {"j_val_pct"});
  EXPECT_FALSE(plots.contains("harmonics")) << "a linear model has no harmonics";
  // The measured and the model's response agree at the resonance.
  const json& s = plots.at("spectrum");
  for (std::size_t k = 0; k < s.at("f").size(); ++k) {
    if (std::abs(s.at("f")[k].get<double>() - kResonanceHz) < 15.0) {
      EXPECT_NEAR(s.at("measured_db")[k].get<double>(), s.at("model_db")[k].get<double>(), 0.5);
    }
  }
  EXPECT_EQ(result.at("summary").at("order"), 2);
}

TEST_F(JobKindsTest, IdentifyLinearMakesItsOwnExcitationAndScansOrders) {
  FakeControl control("j5");
  const json result = run("identify-linear",
                          {{"excite", {{"samples", 2000}, {"validation_samples", 1000}}}, {"scan", {1, 4}}, {"max_iterations", 20}},
                          control);
  expect_progress(control);
  EXPECT_EQ(excitations_, 2);
  EXPECT_EQ(result.at("summary").at("scan").size(), 4u);
  // The smallest order within 5 % of the best validation J is the true one.
  EXPECT_EQ(result.at("summary").at("order"), 2);
  EXPECT_TRUE(store_->find(result.at("model_id").get<std::string>()));
}

TEST_F(JobKindsTest, CancellationInsideTheFitUnwindsTheJob) {
  run("excite", {{"samples", 3000}, {"validation_samples", 1000}}, "j1");
  FakeControl control("j2", 4);
  const json params = validate_job_params("identify-linear", {{"record", "j1"}, {"order", 4}}, env_);
  EXPECT_THROW(job_work("identify-linear", env_)(params, control), JobCancelled);
  EXPECT_TRUE(control.cancelled());
  EXPECT_EQ(control.reports.size(), 4u);
  EXPECT_TRUE(store_->list().empty()) << "a cancelled job stored a model";
}

TEST_F(JobKindsTest, CancellationDuringNarxTraining) {
  FakeControl control("j2", 6);
  const json params = validate_job_params(
      "identify-narx", {{"excite", {{"samples", 1000}, {"validation_samples", 500}}}, {"hidden", {3}}, {"max_iterations", 50}}, env_);
  EXPECT_THROW(job_work("identify-narx", env_)(params, control), JobCancelled);
  EXPECT_TRUE(store_->list().empty());
}

TEST_F(JobKindsTest, IdentifyNarxOnTheVirtualTransducer) {
  use_plant("panel-exciter");
  run("excite", {{"samples", 3000}, {"validation_samples", 1000}, {"amplitude", 0.8}}, "j1");
  FakeControl control("j2");
  const json result = run("identify-narx",
                          {{"record", "j1"}, {"na", 4}, {"nb", 4}, {"hidden", {4}}, {"modes", {"pem", "oem-d"}}, {"max_iterations", 4}},
                          control);
  expect_progress(control);
  bool named_iteration = false;
  for (const Report& r : control.reports) named_iteration = named_iteration || r.message == "oem-d iteration 5";
  EXPECT_TRUE(named_iteration);

  const std::string id = result.at("model_id").get<std::string>();
  ASSERT_TRUE(store_->find(id));
  EXPECT_EQ(store_->find(id)->kind, "narx");
  const models::AnyModel model = models::model_from_json(*store_->model(id));
  EXPECT_EQ(model.kind(), "narx");
  EXPECT_DOUBLE_EQ(model.fs(), kFs);
  // The panel exciter's sensor noise alone leaves a few percent; a short training stays well below 100 %.
  EXPECT_LT(result.at("j_val_pct").get<double>(), 60.0);
  const json& plots = result.at("plots");
  expect_plot(plots.at("fit"), {"t", "measured", "simulated"});
  expect_plot(plots.at("spectrum"), {"f", "measured_db", "model_db"});
  expect_plot(plots.at("history"), {"iteration", "j_est_pct", "j_val_pct"});
  EXPECT_EQ(plots.at("history").at("iteration").size(), std::size_t{result.at("summary").at("iterations").get<std::size_t>() + 1});
  ASSERT_TRUE(plots.contains("harmonics"));
  expect_plot(plots.at("harmonics"), {"f", "measured_h2_db", "measured_h3_db", "model_h2_db", "model_h3_db"});
  EXPECT_EQ(plots.at("harmonics").at("f").size(), 4u);
  // The history is in the model file too, where analyze finds it.
  EXPECT_EQ(store_->model(id)->at("meta").at("history").size(), plots.at("history").at("iteration").size());
}

TEST_F(JobKindsTest, IdentifyNarxSeedsFrictionNodesWhenAsked) {
  use_plant("panel-exciter");
  run("excite", {{"samples", 3000}, {"validation_samples", 1000}, {"amplitude", 0.8}}, "j1");
  // no training: the seeded nodes are the whole difference between the two models
  const json common = {{"record", "j1"}, {"na", 4}, {"nb", 4}, {"hidden", {5}}, {"max_iterations", 0}};
  json seeded_params = common;
  seeded_params["friction_units"] = {2.0, 6.0};
  const json plain = run("identify-narx", common, "j2");
  const json seeded = run("identify-narx", seeded_params, "j3");
  EXPECT_FALSE(plain.at("summary").contains("friction_units"));
  const json& report = seeded.at("summary").at("friction_units");
  EXPECT_EQ(report.at("gains"), json({2.0, 6.0}));
  EXPECT_EQ(report.at("lags"), 1);
  EXPECT_GT(report.at("velocity_fit_r2").get<double>(), 0.5);
  const json a = *store_->model(plain.at("model_id").get<std::string>());
  const json b = *store_->model(seeded.at("model_id").get<std::string>());
  EXPECT_EQ(b.at("meta").at("friction_units"), report);
  const json& ta = a.at("params").at("theta");
  const json& tb = b.at("params").at("theta");
  const std::size_t inputs = 4 + 4 + 1;
  for (std::size_t i = 0; i < inputs; ++i) EXPECT_NEAR(tb[inputs + i].get<double>(), 3.0 * tb[i].get<double>(), 1e-12);
  for (std::size_t i = 2 * inputs; i < ta.size(); ++i) {
    if (i != 5 * inputs && i != 5 * inputs + 1) {
      EXPECT_EQ(ta[i], tb[i]) << "parameter " << i;
    }
  }
}

TEST_F(JobKindsTest, DesignLqMakesAStableControllerThatLoads) {
  const std::string plant = store_reference_model();
  FakeControl control("j3");
  const json result = run("design-lq", {{"plant_model", plant}, {"r", 3.0}, {"band_pass", {{"low_hz", 0}, {"high_hz", 1000}}}}, control);
  expect_progress(control);
  const std::string id = result.at("model_id").get<std::string>();
  ASSERT_TRUE(store_->find(id));
  EXPECT_EQ(store_->find(id)->kind, "lq_feedforward");
  const models::LqFeedforward ff = models::lq_feedforward_from_json(*store_->model(id));
  EXPECT_LT(ff.poles().cwiseAbs().maxCoeff(), 1.0);
  EXPECT_DOUBLE_EQ(ff.weights.R, 3.0);
  EXPECT_EQ(ff.meta.at("model"), plant);
  EXPECT_EQ(ff.meta.at("bandpass"), json({0.0, 1000.0}));
  EXPECT_GT(result.at("summary").at("max_input_noise").get<double>(), 0.0);
  // The drive's peak gain: at least the gain anywhere else, at most ‖h‖₁ = 1/max_input_worst.
  const double peak_db = result.at("summary").at("drive_peak").at("gain_db").get<double>();
  const dsp::SosFilter band(dsp::butterworth_band(2, 0.0, 1000.0, kFs));
  for (const double f : {5.0, 50.0, 150.0, 400.0, 900.0}) {
    EXPECT_LE(20.0 * std::log10(std::abs(band.response(f, kFs) * models::response(ff.controller(), f, kFs))), peak_db + 1e-9)
        << f << " Hz";
  }
  EXPECT_LE(peak_db, -20.0 * std::log10(result.at("summary").at("max_input_worst").get<double>()) + 1e-9);
  EXPECT_EQ(result.at("summary").at("unity_gain_hz"), json(models::unity_gain_hz(ff)));
  expect_plot(result.at("plots").at("spectrum"), {"f", "plant_db", "controlled_db", "controller_db"});
  // The plant's magnitude peaks at its resonance.
  const json& s = result.at("plots").at("spectrum");
  std::size_t top = 0;
  for (std::size_t k = 0; k < s.at("f").size(); ++k) {
    if (s.at("plant_db")[k].get<double>() > s.at("plant_db")[top].get<double>()) top = k;
  }
  EXPECT_NEAR(s.at("f")[top].get<double>(), kResonanceHz, 30.0);
}

TEST_F(JobKindsTest, ControlExcitationPlaysTheFeedforwardsDriveAndWeighsItsHarmonics) {
  const std::string lq = run("design-lq", {{"plant_model", store_reference_model()}, {"r", 3.0}}, "j1").at("model_id");
  FakeControl control("j2");
  const json result = run("excite",
                          {{"signal", "control"}, {"feedforward_model", lq}, {"samples", 3000}, {"validation_samples", 1000},
                           {"sine_peak", 0.5}, {"seed", 4}},
                          control);
  expect_progress(control);
  const ExcitationRecord r = excitation_record_from_result(result, kFs, "j2");
  ASSERT_EQ(r.u_est.size(), 3000);
  ASSERT_EQ(r.u_val.size(), 1000);
  // The drive is the chain's output for the design's program, as panelbass simulate --signal control makes
  // it (models::control_record behind the controller's 20-1200 Hz band-pass), seed 4 then 5.
  const models::LqFeedforward ff = models::lq_feedforward_from_json(*store_->model(lq));
  const std::vector<dsp::Biquad> band = dsp::butterworth_band(2, 20.0, 1200.0, kFs);
  models::FeedbackDesignOptions design;
  design.sine_peak = 0.5;
  design.samples = 3000;
  const models::ControlRecord est = models::control_record(ff, band, design, 4);
  design.samples = 1000;
  const models::ControlRecord val = models::control_record(ff, band, design, 5);
  EXPECT_EQ(r.u_est, est.u);
  EXPECT_EQ(r.u_val, val.u);
  EXPECT_LE(std::max(r.u_est.cwiseAbs().maxCoeff(), r.u_val.cwiseAbs().maxCoeff()), 1.0);
  // The weights are those of the recorded response.
  EXPECT_EQ(r.w_est, models::harmonic_weights(est, r.y_est, kFs));
  EXPECT_EQ(r.w_val, models::harmonic_weights(val, r.y_val, kFs));
  EXPECT_GE(r.w_est.minCoeff(), 0.0);
  EXPECT_GT(r.w_est.maxCoeff(), 0.0);
  EXPECT_EQ(result.at("signal"), "control");
}

TEST_F(JobKindsTest, IdentifyNarxWeightedTrainsWithTheRecordsHarmonicWeights) {
  const std::string lq = run("design-lq", {{"plant_model", store_reference_model()}, {"r", 3.0}}, "j1").at("model_id");
  run("excite", {{"signal", "control"}, {"feedforward_model", lq}, {"samples", 2000}, {"validation_samples", 1000}, {"seed", 4}},
      "j2");
  const json narx = {{"record", "j2"}, {"na", 2}, {"nb", 2}, {"nk", 2}, {"hidden", {3}}, {"max_iterations", 3}};
  json weighted_params = narx;
  weighted_params["weighted"] = true;
  const json weighted = run("identify-narx", weighted_params, "j3");
  const json plain = run("identify-narx", narx, "j4");
  EXPECT_EQ(weighted.at("summary").at("weighted"), true);
  EXPECT_EQ(plain.at("summary").at("weighted"), false);
  const models::NarxModel w = models::narx_model_from_json(*store_->model(weighted.at("model_id").get<std::string>()));
  const models::NarxModel p = models::narx_model_from_json(*store_->model(plain.at("model_id").get<std::string>()));
  EXPECT_EQ(w.meta.at("weighted"), true);
  // The same training written out with the library and the record's weights gives the job's model.
  const ExcitationRecord r = excitation_record_from_result(results_.at("j2"), kFs, "j2");
  const models::Scaling scaling = models::scaling_from_data(r.u_est, r.y_est);
  models::NarxModel start = models::NarxModel::with_structure({2, 2, 2, {3}}, scaling, kFs);
  start.net.initialize(1.0, 1);
  models::TrainingOptions options;
  options.modes = {models::TrainingMode::pem, models::TrainingMode::oem_d};
  options.optimizer = models::Optimizer::lm;
  options.max_iterations = 3;
  options.weights = r.w_est;
  options.validation_weights = r.w_val;
  const models::TrainingResult direct = models::train_narx(start, scaling.scale_u(r.u_est), scaling.scale_y(r.y_est),
                                                           scaling.scale_u(r.u_val), scaling.scale_y(r.y_val), options);
  EXPECT_EQ(w.net.parameters(), direct.model.net.parameters());
  EXPECT_NE(w.net.parameters(), p.net.parameters());
}

TEST_F(JobKindsTest, ControlExcitationAndWeightsAreRefusedWhereTheyCannotApply) {
  const std::string linear = store_reference_model();
  EXPECT_EQ(refusal("excite", {{"signal", "control"}}), "params.feedforward_model: required");
  EXPECT_NE(refusal("excite", {{"signal", "control"}, {"feedforward_model", linear}}).find("expected lq_feedforward"),
            std::string::npos);
  EXPECT_EQ(refusal("excite", {{"signal", "noise"}, {"feedforward_model", linear}}), "params.feedforward_model: unknown field");
  const std::string lq = run("design-lq", {{"plant_model", linear}, {"r", 3.0}}, "j1").at("model_id");
  EXPECT_EQ(refusal("excite", {{"signal", "control"}, {"feedforward_model", lq}, {"samples", 500}}),
            "params.samples: a control excitation needs at least 1000 samples, got 500");
  EXPECT_NE(refusal("excite", {{"signal", "control"}, {"feedforward_model", lq}, {"validation_samples", 500}})
                .find("params.validation_samples: must be 0 (none) or at least 1000"),
            std::string::npos);
  EXPECT_NE(refusal("identify-narx", {{"weighted", true}}).find("params.weighted: the weights come with a control excitation"),
            std::string::npos);
  run("excite", {{"samples", 1000}, {"validation_samples", 0}}, "j5");
  EXPECT_NE(refusal("identify-narx", {{"record", "j5"}, {"weighted", true}}).find("job j5's record has none"), std::string::npos);
  EXPECT_EQ(refusal("identify-narx", {{"weighted", "yes"}}), "params.weighted: expected true or false, got \"yes\"");
  // A plain record is fine unweighted.
  EXPECT_EQ(validate_job_params("identify-narx", {{"record", "j5"}}, env_).at("weighted"), false);
}

TEST_F(JobKindsTest, DesignLqByMaxInputSearchesTheFlattestWeightThatAllowsIt) {
  const std::string plant = store_reference_model();
  const auto safe_amplitude = [&](double r, const std::string& job) {
    return run("design-lq", {{"plant_model", plant}, {"r", r}}, job).at("summary").at("max_input_noise").get<double>();
  };
  const double cheap = safe_amplitude(1e-8, "j1"), expensive = safe_amplitude(3.0, "j2");
  ASSERT_LT(cheap, expensive);
  const double target = 0.5 * (cheap + expensive);
  FakeControl control("j3");
  const json result = run("design-lq", {{"plant_model", plant}, {"max_input", target}}, control);
  expect_progress(control);
  const json& summary = result.at("summary");
  const double R = summary.at("R").get<double>();
  EXPECT_GT(R, 1e-8);
  EXPECT_LT(R, 3.0);
  EXPECT_GE(summary.at("max_input_noise").get<double>(), target);
  EXPECT_EQ(summary.at("R_search").at("target_noise_amplitude"), target);
  // A design 2 % cheaper misses the target: R is the smallest that meets it.
  EXPECT_LT(safe_amplitude(R / 1.02, "j4"), target);
  const models::LqFeedforward ff = models::lq_feedforward_from_json(*store_->model(result.at("model_id").get<std::string>()));
  EXPECT_EQ(ff.weights.R, R);
  EXPECT_EQ(ff.meta.at("R_search"), summary.at("R_search"));
}

TEST_F(JobKindsTest, DesignNnTrainsOnANarxPlantBehindTheLqController) {
  json params = design_nn_models();
  const std::string narx = params.at("plant_model");
  params.update({{"samples", 1000}, {"max_iterations", 3}, {"hidden", {3}}});
  FakeControl control("j3");
  const json result = run("design-nn", params, control);
  expect_progress(control);
  const std::string id = result.at("model_id").get<std::string>();
  ASSERT_TRUE(store_->find(id));
  EXPECT_EQ(store_->find(id)->kind, "neural_feedback");
  const models::NeuralFeedback fb = models::neural_feedback_from_json(*store_->model(id));
  EXPECT_EQ(fb.structure.hidden, std::vector<int>{3});
  EXPECT_EQ(fb.meta.at("plant"), narx);
  const json& history = result.at("plots").at("history");
  expect_plot(history, {"iteration", "j_est_pct", "j_val_pct"});
  EXPECT_LE(history.at("iteration").size(), 4u);
  EXPECT_LE(result.at("j_val_pct").get<double>(), result.at("summary").at("jc_val_before_pct").get<double>());
}

TEST_F(JobKindsTest, DesignNnTakesTheControllersLagsAndTheRecordsShape) {
  json params = design_nn_models();
  params.update({{"samples", 1000}, {"max_iterations", 2}, {"hidden", {3}}, {"nu", 1}, {"nv", 3}, {"ny", 2},
                 {"sine_share", 0.5}, {"sine_peak", 0.4}, {"program_share", 0.25}, {"rail_penalty", 3.0}, {"dc_penalty", 0.5},
                 {"seed", 5}});
  FakeControl control("j3");
  const json result = run("design-nn", params, control);
  expect_progress(control);

  // The stored controller has the lags asked for: N1 takes u(k..k-1), v(k-1..k-3), y(k-1..k-2).
  const std::string id = result.at("model_id").get<std::string>();
  const models::NeuralFeedback fb = models::neural_feedback_from_json(*store_->model(id));
  EXPECT_EQ(fb.structure.nu, 1);
  EXPECT_EQ(fb.structure.nv, 3);
  EXPECT_EQ(fb.structure.ny, 2);
  EXPECT_EQ(fb.structure.inputs(), 7);
  // Summary and meta report what the design ran with (read back from the options it was given).
  const json& summary = result.at("summary");
  for (const json* reported : {&summary, &fb.meta}) {
    for (const char* key : {"samples", "max_iterations", "hidden", "nu", "nv", "ny", "sine_share", "sine_peak",
                            "program_share", "rail_penalty", "dc_penalty", "seed"}) {
      EXPECT_EQ(reported->at(key), params.at(key)) << key;
    }
    EXPECT_EQ(reported->at("restarts"), 1);
    EXPECT_EQ(reported->at("restart_jc_val_pct").size(), 1u);
  }
  EXPECT_EQ(summary.at("chosen_restart"), 0);
  EXPECT_EQ(fb.meta.at("restart"), 0);

  // The record's shape reaches the design: other sine shares make other records, so another J_c before training.
  params.update({{"sine_share", 0.0}, {"max_iterations", 0}});
  const json noise_only = run("design-nn", params, "j4");
  EXPECT_NE(noise_only.at("summary").at("jc_val_before_pct"), summary.at("jc_val_before_pct"));
}

// Tuned on a device (a preset, two playbacks) from a stored controller, with no iteration: the design is
// models::design_feedback's with that device and start (the same first J_c), the weights are the start's, and
// the meta names both; a start with restarts is refused.
TEST_F(JobKindsTest, DesignNnTunesOnADeviceFromAStoredController) {
  json params = design_nn_models();
  params.update({{"samples", 1000}, {"max_iterations", 1}, {"hidden", {3}}, {"desired", "plant-fundamental"}});
  const std::string start_id = run("design-nn", params, "j3").at("model_id");
  params.update({{"max_iterations", 0}, {"tune_on", "linear"}, {"tune_playbacks", 2}, {"start_from", start_id}});
  FakeControl control("j4");
  const json result = run("design-nn", params, control);
  expect_progress(control);
  const models::NeuralFeedback start = models::neural_feedback_from_json(*store_->model(start_id));
  const models::NeuralFeedback tuned =
      models::neural_feedback_from_json(*store_->model(result.at("model_id").get<std::string>()));
  EXPECT_EQ(tuned.net.parameters(), start.net.parameters());
  EXPECT_EQ(tuned.meta.at("tuned_on"), "linear");
  EXPECT_EQ(tuned.meta.at("start_from"), start_id);
  EXPECT_EQ(tuned.meta.at("device_playbacks"), 2);
  EXPECT_EQ(result.at("summary").at("device_playbacks"), 2);
  // the same design by the library: the first validation J_c is the device's, not the plant model's
  models::FeedbackDesignOptions o;
  o.samples = 1000;
  o.structure = start.structure;
  o.desired = models::DesiredResponse::plant_fundamental;
  o.training.max_iterations = 0;
  o.device_playbacks = 2;
  const models::PlantConfig device = models::plant_preset("linear");
  const models::NarxModel plant = models::narx_model_from_json(*store_->model(params.at("plant_model")));
  const models::LqFeedforward ff = models::lq_feedforward_from_json(*store_->model(params.at("feedforward_model")));
  const models::FeedbackDesign expected =
      models::design_feedback(plant, ff, dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs), o, &device, &start);
  EXPECT_DOUBLE_EQ(result.at("summary").at("jc_val_before_pct").get<double>(),
                   expected.training.history.front().jc_val_pct);
  const models::FeedbackDesign on_model =
      models::design_feedback(plant, ff, dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs), o, nullptr, &start);
  EXPECT_NE(result.at("summary").at("jc_val_before_pct").get<double>(), on_model.training.history.front().jc_val_pct);
  params.update({{"restarts", 2}});
  EXPECT_EQ(refusal("design-nn", params), "params.start_from: training on from a controller is one training, and restarts is 2");
}

// The evaluate job is `panelbass chain` + `evaluate`: its rows are engine::evaluate_chain's on a chain built
// here from the same stored models (the feedforward's band-pass from its design), and its attribution is
// engine::attribute_distortion's.
TEST_F(JobKindsTest, EvaluateIsTheChainsEvaluationOnTheVirtualTransducer) {
  use_plant("panel-exciter");
  json models = design_nn_models();
  const json design = run("design-nn", {{"plant_model", models.at("plant_model")}, {"feedforward_model", models.at("feedforward_model")},
                                        {"samples", 1000}, {"max_iterations", 2}, {"hidden", {3}}},
                          "j3");
  const std::string ff = models.at("feedforward_model"), fb = design.at("model_id");
  const json params = {{"feedforward_model", ff}, {"feedback_model", fb}, {"probes_hz", {80.0, 160.0}},
                       {"probe_peak", 0.6}, {"noise_samples", 4096}, {"attribute", true}};
  FakeControl control("j4");
  const json result = run("evaluate", params, control);
  expect_progress(control);

  engine::ChainConfig config;
  config.fs = kFs;
  config.band_pass.design = {engine::Hertz{20.0}, engine::Hertz{1200.0}, 2};
  config.feedforward = engine::SlotConfig{};
  config.feedforward->model = *store_->model(ff);
  config.feedback = engine::SlotConfig{};
  config.feedback->model = *store_->model(fb);
  engine::EvaluationOptions options;
  options.probe_hz = {80.0, 160.0};
  options.probe_peak = 0.6;
  options.noise_samples = 4096;
  const engine::ChainEvaluation expected = engine::evaluate_chain(config, *env_.plant, options);
  ASSERT_EQ(result.at("rows").size(), 3u);
  for (std::size_t r = 0; r < 3; ++r) {
    EXPECT_EQ(result.at("rows")[r], without_non_finite(engine::evaluation_row_to_json(expected.rows[r]))) << r;
  }
  const json& summary = result.at("summary");
  EXPECT_EQ(summary.at("plant"), env_.plant->name) << "the server's own transducer by default";
  EXPECT_EQ(summary.at("feedback_model"), fb);
  EXPECT_EQ(summary.at("source"), "model");
  EXPECT_EQ(summary.at("table").at("band-pass + feedforward + feedback").at("thd_pct")[1],
            expected.rows[2].probes[1].thd_pct);
  expect_plot(result.at("plots").at("response"), {"f", "plant_db", "feedforward_db", "feedback_db"});
  expect_plot(result.at("plots").at("thd"), {"f", "plant_thd_pct", "feedforward_thd_pct", "feedback_thd_pct"});

  const std::vector<engine::TermDistortion> terms = engine::attribute_distortion(config, *env_.plant, options);
  ASSERT_EQ(result.at("attribution").size(), terms.size());
  for (std::size_t t = 0; t < terms.size(); ++t) {
    EXPECT_EQ(result.at("attribution")[t].at("term"), terms[t].term);
    EXPECT_EQ(summary.at("attribution_thd_pct").at(terms[t].term)[1], terms[t].rows[1].probes[1].thd_pct) << terms[t].term;
  }

  // A preset instead, and band-pass + feedforward alone: two rows, no attribution unless asked for.
  const json alone = run("evaluate", {{"feedforward_model", ff}, {"plant", "linear"}, {"probes_hz", {160.0}},
                                      {"noise_samples", 4096}}, "j5");
  EXPECT_EQ(alone.at("rows").size(), 2u);
  EXPECT_EQ(alone.at("summary").at("plant"), "linear");
  EXPECT_EQ(alone.at("summary").at("feedback_model"), nullptr);
  EXPECT_FALSE(alone.contains("attribution"));
}

TEST_F(JobKindsTest, EvaluateRefusalsNameTheField) {
  const json models = design_nn_models();
  const std::string ff = models.at("feedforward_model"), narx = models.at("plant_model");
  const auto refused = [&](const json& extra) {
    json params = {{"feedforward_model", ff}};
    params.update(extra);
    return refusal("evaluate", params);
  };
  EXPECT_NE(refusal("evaluate", json::object()).find("params.feedforward_model"), std::string::npos);
  EXPECT_EQ(refused({{"feedback_model", narx}}),
            "params.feedback_model: model " + narx + " is of kind \"narx\", expected neural_feedback");
  EXPECT_EQ(refused({{"source", "sensor"}}),
            "params.source: \"sensor\" is where a feedback stage takes its past outputs from, and there is no feedback_model");
  // No virtual transducer behind this server: the presets only.
  EXPECT_EQ(refused({{"plant", "server"}}), "params.plant: must be one of \"panel-exciter\", \"linear\", got \"server\"");
  EXPECT_EQ(refused({{"probes_hz", {40.0, 1500.0}}}).substr(0, 19), "params.probes_hz[1]");
  EXPECT_EQ(refused({{"noise_samples", 100}}), "params.noise_samples: must be an integer in [4096, 10000000], got 100");
  EXPECT_EQ(refused({{"probe_peak", 1.5}}), "params.probe_peak: must be a number in [0, 1], got 1.5");
  EXPECT_EQ(refused({{"attribute", "yes"}}), "params.attribute: expected true or false, got \"yes\"");
  EXPECT_EQ(refused({{"speed", 1}}), "params.speed: unknown field");
  use_plant("linear");
  EXPECT_NO_THROW(validate_job_params("evaluate", {{"feedforward_model", ff}, {"plant", "server"}}, env_));
}

TEST_F(JobKindsTest, DesignNnKeepsTheBestOfItsRestarts) {
  json params = design_nn_models();
  params.update({{"samples", 1000}, {"max_iterations", 2}, {"hidden", {3}}, {"restarts", 2}});
  FakeControl control("j3");
  const json result = run("design-nn", params, control);
  expect_progress(control);
  bool named_second_restart = false;
  for (const Report& r : control.reports) named_second_restart = named_second_restart || r.message.starts_with("restart 2/2");
  EXPECT_TRUE(named_second_restart);

  const json& summary = result.at("summary");
  EXPECT_EQ(summary.at("restarts"), 2);
  const std::vector<double> scores = summary.at("restart_jc_val_pct").get<std::vector<double>>();
  ASSERT_EQ(scores.size(), 2u);
  EXPECT_NE(scores[0], scores[1]) << "restarts start from different weights";
  const int chosen = scores[1] < scores[0] ? 1 : 0;
  EXPECT_EQ(summary.at("chosen_restart"), chosen);
  EXPECT_DOUBLE_EQ(result.at("j_val_pct").get<double>(), scores[static_cast<std::size_t>(chosen)]);
  EXPECT_DOUBLE_EQ(summary.at("jc_val_after_pct").get<double>(), scores[static_cast<std::size_t>(chosen)]);
  const json meta = store_->model(result.at("model_id").get<std::string>())->at("meta");
  EXPECT_EQ(meta.at("restart"), chosen);
  EXPECT_EQ(meta.at("restart_jc_val_pct"), summary.at("restart_jc_val_pct"));
}

// The job passes the target, the weighting and the restart choice on as `design nn` takes them: kept by the
// worst probe, the restart kept is the one whose largest THD change over the probes is the most negative.
TEST_F(JobKindsTest, DesignNnCanKeepTheRestartThatCutsItsWorstProbeMost) {
  json params = design_nn_models();
  params.update({{"samples", 1000}, {"max_iterations", 2}, {"hidden", {3}}, {"restarts", 2}, {"desired", "plant-fundamental"},
                 {"weighting", "distortion"}, {"keep", "worst-probe"}, {"probes_hz", {80.0, 200.0}}});
  FakeControl control("j3");
  const json result = run("design-nn", params, control);
  const json& summary = result.at("summary");
  EXPECT_EQ(summary.at("desired"), "plant-fundamental");
  EXPECT_EQ(summary.at("distortion_weighting"), true);
  EXPECT_EQ(summary.at("level_weighting"), false);
  EXPECT_EQ(summary.at("keep"), "worst-probe");
  EXPECT_EQ(summary.at("probe_hz"), json({80.0, 200.0}));
  const json changes = summary.at("restart_probe_change_db");
  ASSERT_EQ(changes.size(), 2u);
  std::vector<double> worst;
  for (const json& c : changes) {
    ASSERT_EQ(c.size(), 2u);
    worst.push_back(std::max(c[0].get<double>(), c[1].get<double>()));
  }
  EXPECT_EQ(summary.at("chosen_restart"), worst[1] < worst[0] ? 1 : 0);
  const json meta = store_->model(result.at("model_id").get<std::string>())->at("meta");
  EXPECT_EQ(meta.at("restart_probe_change_db"), changes);
}

TEST_F(JobKindsTest, AnalyzeJudgesAModelOnARecord) {
  const std::string model = store_reference_model();
  run("excite", {{"samples", 3000}, {"validation_samples", 2000}}, "j1");
  FakeControl control("j2");
  const json result = run("analyze", {{"model", model}, {"record", "j1"}}, control);
  expect_progress(control);
  EXPECT_FALSE(result.contains("model_id"));
  // The reference model is the system itself: J is the noise's share, tiny.
  EXPECT_LT(result.at("j_val_pct").get<double>(), 0.01);
  EXPECT_LT(result.at("j_est_pct").get<double>(), 0.01);
  EXPECT_EQ(result.at("summary").at("kind"), "linear");
  EXPECT_EQ(result.at("summary").at("model"), model);
  expect_plot(result.at("plots").at("fit"), {"t", "measured", "simulated"});
  expect_plot(result.at("plots").at("spectrum"), {"f", "measured_db", "model_db"});
  expect_plot(result.at("plots").at("history"), {"iteration", "j_est_pct", "j_val_pct"}, {"j_val_pct"});
}

TEST_F(JobKindsTest, DiagnoseAgainstAGivenBaseline) {
  const std::string baseline = store_reference_model();
  FakeControl control("j4");
  const json result =
      run("diagnose", {{"excite", {{"samples", 3000}, {"validation_samples", 2000}}}, {"baseline_model", baseline}, {"max_findings", 1}},
          control);
  expect_progress(control);
  EXPECT_TRUE(result.contains("findings"));
  EXPECT_LT(result.at("J_val_before_pct").get<double>(), 0.01);
  EXPECT_LE(result.at("J_val_after_pct").get<double>(), result.at("J_val_before_pct").get<double>());
  expect_plot(result.at("plots").at("fit"), {"t", "measured", "simulated"});
  expect_plot(result.at("plots").at("residual_spectrum"), {"frequency_hz", "before_db", "after_db", "noise_floor_db"});
}

TEST_F(JobKindsTest, AnalyzeANarxModelShowsHarmonicsOfPlantAndModel) {
  use_plant("panel-exciter");
  run("excite", {{"samples", 3000}, {"validation_samples", 1000}, {"amplitude", 0.8}}, "j1");
  const std::string narx =
      run("identify-narx", {{"record", "j1"}, {"na", 4}, {"nb", 4}, {"hidden", {4}}, {"max_iterations", 3}}, "j2").at("model_id");
  FakeControl control("j3");
  const json result = run("analyze", {{"model", narx}, {"record", "j1"}}, control);
  expect_progress(control);
  EXPECT_EQ(result.at("summary").at("kind"), "narx");
  const json& plots = result.at("plots");
  expect_plot(plots.at("fit"), {"t", "measured", "simulated"});
  expect_plot(plots.at("spectrum"), {"f", "measured_db", "model_db"});
  // The training history comes from the model file's meta.
  expect_plot(plots.at("history"), {"iteration", "j_est_pct", "j_val_pct"});
  expect_plot(plots.at("harmonics"), {"f", "measured_h2_db", "measured_h3_db", "model_h2_db", "model_h3_db"});
}

TEST_F(JobKindsTest, DiagnoseFindsItsOwnBaselineOnTheVirtualTransducer) {
  use_plant("panel-exciter");
  FakeControl control("j1");
  const json result =
      run("diagnose", {{"excite", {{"samples", 3000}, {"validation_samples", 2000}, {"amplitude", 0.8}}}, {"max_findings", 1}}, control);
  expect_progress(control);
  EXPECT_EQ(result.at("baseline").at("source"), "identified");
  EXPECT_LE(result.at("J_val_after_pct").get<double>(), result.at("J_val_before_pct").get<double>());
  expect_plot(result.at("plots").at("fit"), {"t", "measured", "simulated"});
  // The residual spectra before and after: the residual's power (Σ of the PSD bins) falls with J.
  const json& spectrum = result.at("plots").at("residual_spectrum");
  expect_plot(spectrum, {"frequency_hz", "before_db", "after_db", "noise_floor_db"});
  double before = 0.0, after = 0.0;
  for (std::size_t k = 0; k < spectrum.at("frequency_hz").size(); ++k) {
    EXPECT_GT(spectrum.at("frequency_hz")[k].get<double>(), 0.0) << "DC is left out";
    before += std::pow(10.0, spectrum.at("before_db")[k].get<double>() / 10.0);
    after += std::pow(10.0, spectrum.at("after_db")[k].get<double>() / 10.0);
  }
  EXPECT_LE(after, 1.01 * before);
  // The noise floor is one level, below the residual before the diagnosis.
  const double floor_db = spectrum.at("noise_floor_db")[0].get<double>();
  for (const json& v : spectrum.at("noise_floor_db")) EXPECT_EQ(v.get<double>(), floor_db);
  EXPECT_LT(std::pow(10.0, floor_db / 10.0) * static_cast<double>(spectrum.at("frequency_hz").size()), before);
}

TEST_F(JobKindsTest, DiagnoseANarxBaselineStartsFromTheJTheAnalyzeJobGivesIt) {
  use_plant("panel-exciter");
  run("excite", {{"samples", 3000}, {"validation_samples", 2000}, {"amplitude", 0.8}}, "j1");
  const std::string narx =
      run("identify-narx", {{"record", "j1"}, {"na", 2}, {"nb", 3}, {"hidden", {3}}, {"max_iterations", 3}}, "j2").at("model_id");
  const double j_analyzed = run("analyze", {{"model", narx}, {"record", "j1"}}, "j3").at("j_val_pct").get<double>();
  FakeControl control("j4");
  const json result = run("diagnose", {{"record", "j1"}, {"baseline_model", narx}, {"max_findings", 1}}, control);
  expect_progress(control);
  EXPECT_EQ(result.at("baseline").at("kind"), "narx");
  EXPECT_NEAR(result.at("J_val_before_pct").get<double>(), j_analyzed, 1e-6 * j_analyzed);
  EXPECT_LE(result.at("J_val_after_pct").get<double>(), result.at("J_val_before_pct").get<double>());
  expect_plot(result.at("plots").at("residual_spectrum"), {"frequency_hz", "before_db", "after_db", "noise_floor_db"});
}

TEST_F(JobKindsTest, DiagnoseRefusesABaselineThatIsNotASimulation) {
  const std::string lq = run("design-lq", {{"plant_model", store_reference_model()}, {"r", 3.0}}, "j1").at("model_id");
  try {
    validate_job_params("diagnose", {{"baseline_model", lq}}, env_);
    FAIL() << "an LQ feedforward is not a simulation of the plant";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("baseline_model"), std::string::npos) << e.what();
  }
}

TEST_F(JobKindsTest, TheSameSeedRecordsTheSameExcitation) {
  const json a = run("excite", {{"samples", 500}, {"validation_samples", 300}, {"seed", 9}}, "j1");
  excitations_ = 0;  // the fake backend's noise is seeded by its call count
  const json b = run("excite", {{"samples", 500}, {"validation_samples", 300}, {"seed", 9}}, "j2");
  EXPECT_EQ(a.at("record"), b.at("record"));
  const json c = run("excite", {{"samples", 500}, {"validation_samples", 300}, {"seed", 10}}, "j3");
  EXPECT_NE(a.at("record").at("u_est"), c.at("record").at("u_est"));
}

TEST_F(JobKindsTest, WithoutValidationDataTheValidationFiguresAreNull) {
  const json result =
      run("identify-linear", {{"excite", {{"samples", 2000}, {"validation_samples", 0}}}, {"method", "arx"}, {"order", 2}}, "j1");
  EXPECT_TRUE(result.at("j_val_pct").is_null());
  EXPECT_LT(result.at("j_est_pct").get<double>(), 0.01);
  // ARX has no iterations: the history is the final model's one point.
  const json& history = result.at("plots").at("history");
  expect_plot(history, {"iteration", "j_est_pct", "j_val_pct"}, {"j_val_pct"});
  EXPECT_EQ(history.at("iteration").size(), 1u);
  EXPECT_TRUE(history.at("j_val_pct")[0].is_null());
  // The fit is shown on the estimation part.
  EXPECT_EQ(result.at("plots").at("fit").at("t").size(), 1950u);
  EXPECT_EQ(store_->model(result.at("model_id").get<std::string>())->at("meta").at("J_val_pct"), nullptr);
}

TEST_F(JobKindsTest, ABackendThatRecordsTooLittleFailsTheJob) {
  env_.excite = [](const Eigen::VectorXd& drive) { return Eigen::VectorXd(drive.head(drive.size() - 1)); };
  FakeControl control("j1");
  const json params = validate_job_params("excite", {{"samples", 300}}, env_);
  const std::string message =
      testing_support::message_of<std::runtime_error>([&] { job_work("excite", env_)(params, control); });
  EXPECT_EQ(message, "the backend recorded 299 samples for a drive of 300");
}

}  // namespace
}  // namespace panelbass::api

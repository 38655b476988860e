#pragma once
// What the job kind tests share: a fake job control that records progress, the reference system the fake
// backend plays through (a second-order system written as its textbook difference equation,
// tests/support/linear_systems.h) or the virtual transducer, the checks every result and plot must pass,
// and the fixture that validates and runs a kind against that environment.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "api/jobs/job_kinds.h"
#include "api/model_store.h"
#include "api/jobs/excitation_record.h"
#include "api/model_validation.h"
#include "api/jobs/job_plots.h"
#include "evaluation/chain_evaluation.h"
#include "engine/chain_file.h"
#include "evaluation/distortion_attribution.h"
#include "evaluation/evaluation_json.h"
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

namespace panelbass::api::job_testing {

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
inline constexpr double kFs = 3000.0;
inline constexpr double kRadius = 0.9;
inline constexpr double kResonanceHz = 300.0;

inline models::TransferFunction reference_system() {
  const double theta = 2.0 * std::numbers::pi * kResonanceHz / kFs;
  models::TransferFunction tf;
  tf.a = Eigen::Vector2d(-2.0 * kRadius * std::cos(theta), kRadius * kRadius);
  tf.b = Eigen::Vector2d(0.3, 0.2);
  tf.nk = 1;
  return tf;
}

// Every number in `value` finite (no NaN or infinity left in a result).
inline bool finite_everywhere(const json& value) {
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
inline void expect_plot(const json& plot, const std::vector<std::string>& columns, const std::vector<std::string>& nullable = {}) {
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
inline void expect_progress(const FakeControl& control) {
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

/// The samples of array `a` (an excite job's record column).
inline Eigen::VectorXd samples_of(const nlohmann::json& a) {
  const std::vector<double> v = a.get<std::vector<double>>();
  return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
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

}  // namespace panelbass::api::job_testing

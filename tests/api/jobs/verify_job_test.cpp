// The verify job at equal output level against a backend whose distortion and noise are known: the response is the
// drive plus c·drive² plus white Gaussian noise of σ. For a probe A·sin, c·A²·sin² = c·A²/2·(1 − cos 2ωt), so the
// transducer alone gives a fundamental of A and, in closed form, a THD of 100·(c·A/2)/A = 50·c·A percent.

#include <gtest/gtest.h>

#include <cmath>

#include "tests/api/jobs/job_test_fixture.h"

namespace panelbass::api::job_testing {
namespace {

class VerifyJobTest : public JobKindsTest {
 protected:
  // The backend: drive + c·drive² + seeded noise of σ.
  void use_square_law(double c, double sigma) {
    env_.excite = [this, c, sigma](const Eigen::VectorXd& drive) {
      ++excitations_;
      return Eigen::VectorXd(drive + c * drive.cwiseProduct(drive) +
                             testing_support::gaussian(drive.size(), sigma, 300 + excitations_));
    };
  }

  // Verifies an LQ feedforward of the reference system at 80 Hz, program level 0.2; the point's row.
  json point() {
    const std::string lq = run("design-lq", {{"plant_model", store_reference_model()}, {"r", 3.0}}, "j1").at("model_id");
    FakeControl control("j2");
    const json result = run("verify", {{"feedforward_model", lq}, {"frequencies", {80.0}}, {"levels", {0.2}}}, control);
    expect_progress(control);
    return result.at("points").at(0);
  }
};

constexpr double kSquareLaw = 0.1;

TEST_F(VerifyJobTest, TheTransducerAloneIsReadAtEqualOutputToItsClosedFormThd) {
  use_square_law(kSquareLaw, 1e-5);
  const json p = point();
  ASSERT_TRUE(p.at("reachable").get<bool>()) << p.dump();
  // y = d + c·d²: a sine of amplitude A comes out with its fundamental A and a THD of 50·c·A percent
  const double a = p.at("plant_drive").get<double>();
  EXPECT_NEAR(p.at("plant_output_level").get<double>(), a, 1e-3 * a) << p.dump();
  EXPECT_NEAR(p.at("plant").at("thd_pct").get<double>(), 50.0 * kSquareLaw * a, 0.01 * 50.0 * kSquareLaw * a) << p.dump();
  // matched to the chain's output within 0.1 dB
  EXPECT_NEAR(20.0 * std::log10(p.at("plant_output_level").get<double>() / p.at("output_level").get<double>()), 0.0, 0.1);
  // both read above their noise: the cut is their ratio, positive for less distortion
  ASSERT_TRUE(p.at("thd_cut_db").is_number()) << p.dump();
  EXPECT_NEAR(p.at("thd_cut_db").get<double>(),
              20.0 * std::log10(p.at("plant").at("thd_pct").get<double>() / p.at("chain").at("thd_pct").get<double>()), 1e-9);
}

TEST_F(VerifyJobTest, ATHDAtTheNoiseIsSaidToBeThereNotGivenAsANumber) {
  use_square_law(0.0, 0.0033);  // no distortion: what the harmonics' bins read is noise
  const json p = point();
  EXPECT_TRUE(p.at("plant").at("noise_bound").get<bool>()) << p.dump();
  EXPECT_TRUE(p.at("plant").at("thd_pct").is_null());
  EXPECT_GT(p.at("plant").at("at_most_pct").get<double>(), 0.0);
  EXPECT_TRUE(p.at("thd_cut_db").is_null());
  EXPECT_TRUE(p.at("thd_cut_at_least_db").is_null()) << "nothing to cut: no bound either";
}

}  // namespace
}  // namespace panelbass::api::job_testing

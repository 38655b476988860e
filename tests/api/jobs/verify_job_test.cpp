// The verify job's THD readings against a backend whose distortion and noise are known: the response is the
// drive plus c·drive² plus white Gaussian noise of σ. For a probe A·sin, c·A²·sin² = c·A²/2·(1 − cos 2ωt), so the
// THD without the chain is, in closed form, 100·(c·A/2)/A = 50·c·A percent; the noise's floor is
// 100·sqrt(4·4σ²/N)/A over N samples (dsp::steady_thd, tested in tests/dsp/harmonics_test.cpp).

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

  // Verifies an LQ feedforward of the reference system at 80 Hz, level 0.2; the probe's row.
  json probe() {
    const std::string lq = run("design-lq", {{"plant_model", store_reference_model()}, {"r", 3.0}}, "j1").at("model_id");
    FakeControl control("j2");
    const json result = run("verify", {{"feedforward_model", lq}, {"frequencies", {80.0}}, {"level", 0.2}}, control);
    expect_progress(control);
    return result.at("probes").at(0);
  }
};

constexpr double kSquareLaw = 0.1;                      // THD without the chain: 50·0.1·0.2 = 1 %
constexpr double kClosedFormThdPct = 50.0 * kSquareLaw * 0.2;

TEST_F(VerifyJobTest, AQuietReadingIsTheClosedFormAtTheFirstLength) {
  use_square_law(kSquareLaw, 1e-5);
  const json p = probe();
  EXPECT_NEAR(p.at("thd_before_pct").get<double>(), kClosedFormThdPct, 0.01 * kClosedFormThdPct) << p.dump();
  EXPECT_FALSE(p.at("thd_before_at_floor").get<bool>());
  EXPECT_LT(p.at("thd_before_uncertainty_db").get<double>(), 0.2);
  EXPECT_DOUBLE_EQ(p.at("seconds_before").get<double>(), 0.5) << "no need to play longer";
  // Both readings above the floor: the change and the cut are one figure, of opposite signs (a cut is less THD).
  ASSERT_TRUE(p.at("thd_change_db").is_number()) << p.dump();
  EXPECT_EQ(p.at("thd_cut_db").get<double>(), -p.at("thd_change_db").get<double>());
  EXPECT_NEAR(p.at("thd_change_db").get<double>(),
              20.0 * std::log10(p.at("thd_after_pct").get<double>() / p.at("thd_before_pct").get<double>()), 1e-12);
  const double n = 0.75 * 0.5 * kFs;  // about the stretch read
  EXPECT_NEAR(p.at("thd_before_floor_pct").get<double>(), 100.0 * std::sqrt(16.0 * 1e-10 / n) / 0.2,
              0.2 * 100.0 * std::sqrt(16.0 * 1e-10 / n) / 0.2);
}

TEST_F(VerifyJobTest, ANoisyReadingIsPlayedLongerUntilTheNoiseMovesItLessThanAFifthOfADecibel) {
  // At 0.5 s this noise moves a 1 % THD by about 0.6 dB.
  use_square_law(kSquareLaw, 0.0033);
  const json p = probe();
  const double seconds = p.at("seconds_before").get<double>(), uncertainty = p.at("thd_before_uncertainty_db").get<double>();
  EXPECT_GT(seconds, 0.5) << p.dump();
  EXPECT_LE(seconds, 8.0);
  EXPECT_TRUE(uncertainty <= 0.2 || seconds == 8.0) << p.dump();
  EXPECT_NEAR(20.0 * std::log10(p.at("thd_before_pct").get<double>() / kClosedFormThdPct), 0.0, 3.0 * uncertainty) << p.dump();
}

TEST_F(VerifyJobTest, ATHDAtTheNoiseFloorIsSaidToBeThereNotGivenAsANumber) {
  use_square_law(0.0, 0.0033);  // no distortion: what the harmonics' bins read is noise
  const json p = probe();
  EXPECT_TRUE(p.at("thd_before_at_floor").get<bool>()) << p.dump();
  EXPECT_TRUE(p.at("thd_before_pct").is_null());
  EXPECT_DOUBLE_EQ(p.at("seconds_before").get<double>(), 8.0) << "played as long as allowed, the floor lowered";
  EXPECT_TRUE(p.at("thd_change_db").is_null());
  EXPECT_NE(p.at("note").get<std::string>().find("noise floor"), std::string::npos) << p.dump();
}

}  // namespace
}  // namespace panelbass::api::job_testing

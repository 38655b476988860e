#include "usecases/excite.h"

#include <gtest/gtest.h>

#include <cmath>

#include "dsp/excitation.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

// The field a request is refused for.
std::string refused_field(const ExciteRequest& q) {
  try {
    check(q);
  } catch (const RequestError& e) {
    return e.field();
  }
  return "";
}

ExciteRequest small_request() {
  ExciteRequest q;
  q.samples = 1000;
  q.validation_samples = 400;
  q.fs = 3000.0;
  return q;
}

// A backend that returns twice the drive, a current of its square and a report per play: what comes back is known.
PlayFunction doubling(int& plays) {
  return [&plays](const Eigen::VectorXd& drive) {
    ++plays;
    return Playback{2.0 * drive, drive.cwiseProduct(drive), Eigen::VectorXd(), nlohmann::json{{"play", plays}}};
  };
}

TEST(Excite, TheTwoPartsAreTheSeededDrivesAndWhatCameBack) {
  int plays = 0;
  SilentProgress quiet;
  const ExciteRequest q = small_request();
  const ExciteReport r = excite(q, doubling(plays), quiet);
  EXPECT_EQ(plays, 2);
  // The estimation part is uniform noise seeded `seed`, the validation part seeded seed + 1, each of its length.
  EXPECT_EQ(r.record.u_est, dsp::uniform_noise(1000, q.amplitude, q.seed));
  EXPECT_EQ(r.record.u_val, dsp::uniform_noise(400, q.amplitude, q.seed + 1));
  EXPECT_EQ(r.record.y_est, 2.0 * r.record.u_est);
  EXPECT_EQ(r.record.i_val, r.record.u_val.cwiseProduct(r.record.u_val));
  EXPECT_EQ(r.record.l_est.size(), 0) << "nothing looped back";
  // Each play's report is kept, in order.
  EXPECT_EQ(r.record.card, (nlohmann::json{{{"play", 1}}, {{"play", 2}}}));
  // RMS over both parts, by its definition.
  const double drive_rms = std::sqrt((r.record.u_est.squaredNorm() + r.record.u_val.squaredNorm()) / 1400.0);
  EXPECT_NEAR(r.summary.at("rms_drive").get<double>(), drive_rms, 1e-15);
  EXPECT_NEAR(r.summary.at("rms_response").get<double>(), 2.0 * drive_rms, 1e-15);
  EXPECT_LE(r.record.u_est.cwiseAbs().maxCoeff(), q.amplitude);
}

TEST(Excite, ABackendThatRecordsNoSensorOrTooLittleIsToldSo) {
  SilentProgress quiet;
  const PlayFunction deaf = [](const Eigen::VectorXd&) { return Playback{}; };
  EXPECT_THROW(excite(small_request(), deaf, quiet), std::runtime_error);
  const PlayFunction short_one = [](const Eigen::VectorXd& drive) {
    return Playback{drive.head(drive.size() - 1), Eigen::VectorXd(), Eigen::VectorXd(), nullptr};
  };
  EXPECT_THROW(excite(small_request(), short_one, quiet), std::runtime_error);
}

TEST(Excite, ARequestOutOfRangeNamesItsField) {
  ExciteRequest q = small_request();
  EXPECT_EQ(refused_field(q), "");
  q.samples = 199;
  EXPECT_EQ(refused_field(q), "samples");
  q = small_request();
  q.validation_samples = 100;
  EXPECT_EQ(refused_field(q), "validation_samples");
  q = small_request();
  q.safe_level = 0.2;
  EXPECT_EQ(refused_field(q), "amplitude") << "0.3 is beyond the safe level";
  q = small_request();
  q.signal = "sweep";
  EXPECT_EQ(refused_field(q), "signal");
  q = small_request();
  q.signal = "control";
  q.samples = 2000;
  q.validation_samples = 0;
  EXPECT_EQ(refused_field(q), "feedforward_model") << "a control excitation plays a feedforward's drive";
}

}  // namespace
}  // namespace panelbass::usecases

// The sensor watch against counts written out by hand: lost after exactly `timeout` silent samples while
// the model predicts signal, never while the model agrees the output is silent, back after `timeout`
// samples of signal.
#include "engine/sensor_watch.h"

#include <gtest/gtest.h>

namespace panelbass::engine {
namespace {

TEST(SensorWatch, IsLostAfterTimeoutSilentSamplesWhileTheModelPredictsSignal) {
  SensorWatch watch({.silence = 1e-6, .timeout = 10});
  for (int k = 0; k < 50; ++k) EXPECT_FALSE(watch.update(0.3, 0.3));  // present
  for (int k = 0; k < 9; ++k) EXPECT_FALSE(watch.update(0.0, 0.2)) << k;
  EXPECT_TRUE(watch.update(0.0, 0.2));  // the 10th silent sample
  EXPECT_TRUE(watch.lost());
  for (int k = 0; k < 9; ++k) EXPECT_FALSE(watch.update(0.1, 0.2)) << k;
  EXPECT_TRUE(watch.update(0.1, 0.2));  // the 10th loud sample
  EXPECT_FALSE(watch.lost());
}

TEST(SensorWatch, SilenceTheModelAgreesWithIsNotALoss) {
  SensorWatch watch({.silence = 1e-6, .timeout = 10});
  for (int k = 0; k < 1000; ++k) EXPECT_FALSE(watch.update(0.0, 5e-6));  // RMS 5e-6 < 10·silence
  EXPECT_FALSE(watch.lost());
}

TEST(SensorWatch, ASingleReadingAboveSilenceRestartsTheCount) {
  SensorWatch watch({.silence = 1e-6, .timeout = 10});
  for (int k = 0; k < 9; ++k) watch.update(0.0, 0.5);
  watch.update(2e-6, 0.5);  // one sample above silence
  for (int k = 0; k < 9; ++k) EXPECT_FALSE(watch.update(0.0, 0.5));
  EXPECT_TRUE(watch.update(0.0, 0.5));
  watch.reset();
  EXPECT_FALSE(watch.lost());
}

}  // namespace
}  // namespace panelbass::engine

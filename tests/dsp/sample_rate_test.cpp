// same_rate: the one tolerance every layer compares sample rates by.
#include "dsp/sample_rate.h"

#include <gtest/gtest.h>

#include <limits>

namespace panelbass::dsp {
namespace {

TEST(SameRate, AgreesToAPartInABillionOfTheLarger) {
  EXPECT_TRUE(same_rate(3000.0, 3000.0));
  EXPECT_TRUE(same_rate(48000.0, 48000.0 * (1.0 + 0.9e-9)));   // 0.9 parts in 10⁹
  EXPECT_FALSE(same_rate(48000.0, 48000.0 * (1.0 + 1.1e-9)));  // 1.1 parts in 10⁹
  EXPECT_TRUE(same_rate(48000.0 / 16.0, 3000.0));              // a ratio that is exact
  EXPECT_FALSE(same_rate(44100.0, 48000.0));
}

TEST(SameRate, IsSymmetricAndRejectsNaN) {
  const double a = 3000.0, b = 3000.0 * (1.0 + 0.95e-9);
  EXPECT_EQ(same_rate(a, b), same_rate(b, a));
  EXPECT_FALSE(same_rate(std::numeric_limits<double>::quiet_NaN(), 3000.0));
  EXPECT_FALSE(same_rate(3000.0, std::numeric_limits<double>::quiet_NaN()));
}

}  // namespace
}  // namespace panelbass::dsp

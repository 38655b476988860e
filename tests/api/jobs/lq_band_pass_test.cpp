// The band-pass an LQ controller was designed behind, read from its meta as `design lq` writes it, with
// the defaults (20 Hz to min(1200 Hz, 0.45·fs), order 2) where the meta is missing or out of range.

#include "api/jobs/lq_band_pass.h"

#include <gtest/gtest.h>

namespace panelbass::api {
namespace {

models::LqFeedforward controller(double fs, nlohmann::json meta) {
  models::LqFeedforward ff;
  ff.fs = fs;
  ff.meta = std::move(meta);
  return ff;
}

TEST(LqBandPass, TheMetaGivesCornersAndOrder) {
  const LqBandPass band = lq_band_pass(controller(3000.0, {{"bandpass", {40.0, 800.0}}, {"bandpass_order", 4}}));
  EXPECT_EQ(band.low_hz, 40.0);
  EXPECT_EQ(band.high_hz, 800.0);
  EXPECT_EQ(band.order, 4);
  EXPECT_FALSE(band.filter.empty());
}

TEST(LqBandPass, WithoutMetaTheDefaultsKeepTheUpperCornerBelowNyquist) {
  const LqBandPass band = lq_band_pass(controller(2000.0, nlohmann::json::object()));
  EXPECT_EQ(band.low_hz, 20.0);
  EXPECT_EQ(band.high_hz, 900.0);  // 0.45 · 2000 Hz, below the 1200 Hz default
  EXPECT_EQ(band.order, 2);
}

TEST(LqBandPass, AnEntryOutOfRangeIsIgnored) {
  const LqBandPass band = lq_band_pass(controller(3000.0, {{"bandpass", {40.0, 1600.0}}, {"bandpass_order", 17}}));
  EXPECT_EQ(band.low_hz, 20.0);
  EXPECT_EQ(band.high_hz, 1200.0);
  EXPECT_EQ(band.order, 2);
}

}  // namespace
}  // namespace panelbass::api

// Metrics: the histogram bins cover every time in order, p50/p99/mean/max of known block times, and a
// reader thread that snapshots while the writer records.
#include "engine/metrics.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

namespace panelbass::engine {
namespace {

TEST(Metrics, HistogramBinsAreOrderedAndContainTheirTimes) {
  for (std::uint64_t ns : {0ull, 1ull, 7ull, 8ull, 9ull, 15ull, 16ull, 1000ull, 123456789ull, ~0ull}) {
    const std::size_t b = Metrics::bin_of(ns);
    ASSERT_LT(b, Metrics::kBins);
    EXPECT_LT(static_cast<double>(ns), Metrics::bin_upper_ns(b) * (1 + 1e-15)) << ns;
    if (b > 0) {
      EXPECT_GE(static_cast<double>(ns), Metrics::bin_upper_ns(b - 1)) << ns;
    }
  }
  for (std::size_t b = 1; b < Metrics::kBins; ++b) EXPECT_GT(Metrics::bin_upper_ns(b), Metrics::bin_upper_ns(b - 1));
}

TEST(Metrics, MeanP99AndMaxOfKnownBlockTimes) {
  Metrics m;
  m.set_rate(3000.0);
  for (int i = 0; i < 995; ++i) m.record_block(1000, 64);
  for (int i = 0; i < 5; ++i) m.record_block(1'000'000, 64);
  MetricsSnapshot s = m.snapshot();
  EXPECT_EQ(s.blocks, 1000u);
  EXPECT_EQ(s.samples, 64000u);
  EXPECT_DOUBLE_EQ(s.mean_block_ns, (995 * 1000.0 + 5 * 1e6) / 1000);
  EXPECT_DOUBLE_EQ(s.max_block_ns, 1e6);
  // 99.5 % of the blocks took 1000 ns: p99 is the upper edge of 1000's bin (within a quarter octave).
  EXPECT_GE(s.p99_block_ns, 1000.0);
  EXPECT_LE(s.p99_block_ns, 1250.0);
  EXPECT_DOUBLE_EQ(s.load, (995 * 1000.0 + 5 * 1e6) / (64000 / 3000.0 * 1e9));
  for (int i = 0; i < 6; ++i) m.record_block(1'000'000, 64);  // 11 of 1006 slow: p99 is in the slow bin

  s = m.snapshot();
  EXPECT_DOUBLE_EQ(s.p99_block_ns, 1e6);
  // The median is still a 1000 ns block.
  EXPECT_GE(s.p50_block_ns, 1000.0);
  EXPECT_LE(s.p50_block_ns, 1250.0);
  // Half and half: the median is the fast bin's edge; one more slow block moves it to the slow bin.
  Metrics half;
  for (int i = 0; i < 50; ++i) half.record_block(1000, 64);
  for (int i = 0; i < 50; ++i) half.record_block(1'000'000, 64);
  EXPECT_LE(half.snapshot().p50_block_ns, 1250.0);
  half.record_block(1'000'000, 64);
  EXPECT_DOUBLE_EQ(half.snapshot().p50_block_ns, 1e6);
}

TEST(Metrics, FaultsSwapsXrunsAndActiveIds) {
  Metrics m;
  m.record_fault(Fault::pinned);
  m.set_in_fault(true);
  m.record_swap();
  m.record_xrun();
  m.set_active_id(1, 42);
  const MetricsSnapshot s = m.snapshot();
  EXPECT_EQ(s.faults, 1u);
  EXPECT_TRUE(s.in_fault);
  EXPECT_EQ(s.last_fault, Fault::pinned);
  EXPECT_STREQ(fault_name(s.last_fault), "drive pinned at the rails");
  EXPECT_EQ(s.swaps, 1u);
  EXPECT_EQ(s.xruns, 1u);
  EXPECT_EQ(s.active_ids[1], 42u);
}

TEST(Metrics, TheLatestBlockIsKept) {
  Metrics m;
  EXPECT_EQ(m.snapshot().max_late_ns, 0.0);
  for (const std::uint64_t ns : {300u, 7000u, 20u}) m.record_lateness(ns);
  EXPECT_EQ(m.snapshot().max_late_ns, 7000.0);
}

TEST(Metrics, AnotherThreadReadsWhileTheAudioThreadWrites) {
  Metrics m;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (int i = 0; i < 20000; ++i) m.record_block(500 + i % 100, 32);
    done = true;
  });
  std::uint64_t last = 0;
  while (!done) {
    const MetricsSnapshot s = m.snapshot();
    EXPECT_GE(s.blocks, last);  // counters only grow
    last = s.blocks;
  }
  writer.join();
  EXPECT_EQ(m.snapshot().blocks, 20000u);
}

}  // namespace
}  // namespace panelbass::engine

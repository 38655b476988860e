// The slot's history ring: what a snapshot holds (the newest final samples, oldest first, measured 0
// until observed), and, with a writer thread pushing as fast as it can, that every snapshot the control
// thread takes is a run of consecutive, untorn samples (the seqlock drops what was overwritten).
#include "engine/history_ring.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>
#include <vector>

namespace panelbass::engine {
namespace {

TEST(HistoryRing, ASnapshotHoldsTheNewestFinalSamplesOldestFirst) {
  HistoryRing ring(4);
  HistoryRing::Snapshot s;
  ring.snapshot(4, s);
  EXPECT_TRUE(s.input.empty());
  EXPECT_EQ(s.end, 0u);
  for (int k = 0; k < 6; ++k) {
    ring.push_input(k);
    ring.set_measured(10.0 * k);
  }
  ring.push_input(6.0);  // not observed yet: sample 6 is not final, sample 5 is
  ring.snapshot(3, s);
  EXPECT_EQ(s.end, 6u);
  EXPECT_EQ(s.input, (std::vector<double>{3.0, 4.0, 5.0}));
  EXPECT_EQ(s.measured, (std::vector<double>{30.0, 40.0, 50.0}));
  ring.push_input(7.0);  // sample 6 final without an observation: measured 0; sample 7 took sample 3's place
  ring.snapshot(10, s);
  EXPECT_EQ(s.end, 7u);
  EXPECT_EQ(s.input, (std::vector<double>{4.0, 5.0, 6.0}));
  EXPECT_EQ(s.measured, (std::vector<double>{40.0, 50.0, 0.0}));
  EXPECT_EQ(ring.count(), 8u);
  EXPECT_EQ(ring.input(7), 7.0);
  EXPECT_EQ(ring.measured(5), 50.0);
}

TEST(HistoryRing, ABlockPushIsTheSamplesPushedOneByOneWithMeasuredZero) {
  for (std::size_t length : {0, 5, 16}) {
    HistoryRing by_sample(length), by_block(length);
    std::vector<double> x(23);
    for (std::size_t k = 0; k < x.size(); ++k) x[k] = 1.0 + static_cast<double>(k);
    // 10 samples observed, then 7 of which the last is not (the chain stopped observing the slot there),
    // then 6 observed: as push_input() and set_measured(0) would leave the ring.
    for (std::size_t k = 0; k < 23; ++k) {
      by_sample.push_input(x[k]);
      if (k != 16) by_sample.set_measured(0.0);
    }
    by_block.push_block({x.data(), 10}, 10);
    by_block.push_block({x.data() + 10, 7}, 6);
    HistoryRing::Snapshot mid_block;
    by_block.snapshot(16, mid_block);
    EXPECT_EQ(mid_block.end, 16u);
    by_block.push_block({x.data() + 17, 6}, 6);
    HistoryRing::Snapshot a, b;
    by_sample.snapshot(30, a);
    by_block.snapshot(30, b);
    EXPECT_EQ(b.end, a.end);
    EXPECT_EQ(b.input, a.input);
    EXPECT_EQ(b.measured, a.measured);
    EXPECT_EQ(by_block.count(), by_sample.count());
  }
}

TEST(HistoryRing, WithoutLengthItOnlyCounts) {
  HistoryRing ring(0);
  ring.push_input(1.0);
  ring.set_measured(2.0);
  HistoryRing::Snapshot s;
  ring.snapshot(8, s);
  EXPECT_TRUE(s.input.empty());
  EXPECT_EQ(s.end, 1u);
  EXPECT_EQ(ring.count(), 1u);
}

TEST(HistoryRing, SnapshotsTakenWhileTheAudioThreadWritesAreConsecutiveAndUntorn) {
  HistoryRing ring(256);
  std::atomic<bool> stop{false};
  std::atomic<bool> filled{false};
  std::atomic<int> spin{0};
  std::thread writer([&] {
    for (std::uint64_t k = 0; !stop.load(std::memory_order_relaxed); ++k) {
      ring.push_input(static_cast<double>(k));
      ring.set_measured(-static_cast<double>(k));
      if (k == 256) filled.store(true, std::memory_order_release);
      // A little slower than the reader's copy, so most snapshots keep samples.
      for (int pause = 0; pause < 20; ++pause) spin.fetch_add(1, std::memory_order_relaxed);
    }
  });
  while (!filled.load(std::memory_order_acquire)) std::this_thread::yield();
  HistoryRing::Snapshot s;
  std::size_t nonempty = 0;
  for (int i = 0; i < 20000; ++i) {
    ring.snapshot(256, s);
    ASSERT_EQ(s.input.size(), s.measured.size());
    ASSERT_LE(s.input.size(), 256u);
    if (!s.input.empty()) ++nonempty;
    for (std::size_t j = 0; j < s.input.size(); ++j) {
      const double k = static_cast<double>(s.end - s.input.size() + j);
      ASSERT_EQ(s.input[j], k) << i;
      ASSERT_EQ(s.measured[j], -k) << i;
    }
  }
  stop = true;
  writer.join();
  EXPECT_GT(nonempty, 0u);
}

}  // namespace
}  // namespace panelbass::engine

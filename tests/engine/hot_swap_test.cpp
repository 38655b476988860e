// Hot swap under load: 1000 installs at random moments while the virtual backend runs as fast as it
// can. The output never steps further from one sample to the next than either model's output does on
// its own (bounds computed here by rendering each model alone), and every retired stage is freed.
#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>
#include <thread>
#include <vector>

#include "dsp/random.h"
#include "engine/chain.h"
#include "engine/offline_renderer.h"
#include "engine/virtual_backend.h"
#include "models/plant/plant_presets.h"
#include "tests/engine/engine_test_models.h"
#include "tests/support/model_stages.h"

namespace panelbass::engine {
namespace {

using testing::kFs;

std::atomic<int> created{0}, destroyed{0};

/// A linear stage that counts its constructions and destructions.
class CountedLinearStage final : public LinearStage {
 public:
  explicit CountedLinearStage(const models::LinearModel& m) : LinearStage(m) { ++created; }
  ~CountedLinearStage() override { ++destroyed; }
};

// One period (1 s) of a six-tone program; looping it is seamless.
std::vector<double> periodic_program() {
  std::vector<double> x(3000, 0.0);
  for (double f : {37.0, 110.0, 230.0, 370.0, 610.0, 890.0}) {
    for (std::size_t k = 0; k < x.size(); ++k) x[k] += 0.12 * std::sin(2 * std::numbers::pi * f * k / kFs + f);
  }
  return x;
}

TEST(HotSwap, AThousandSwapsWhileRunningAddNoStepAndFreeEveryRetiredStage) {
  // Two feedforward models that differ in gain, resonance and delay.
  const models::LinearModel a_model = testing::resonant_linear(0.9, 0.5, Eigen::Vector2d(0.15, 0.1), 0);
  const models::LinearModel b_model = testing::resonant_linear(0.85, 0.7, Eigen::Vector2d(0.3, 0.12), 1);
  ChainOptions options;
  options.spec.max_block = 64;
  options.slots = {Samples{64}, Samples{512}};
  const std::vector<double> period = periodic_program();

  // Each model on its own through the same chain, three periods from rest.
  Eigen::VectorXd program(3 * period.size());
  for (Eigen::Index k = 0; k < program.size(); ++k) program[k] = period[static_cast<std::size_t>(k) % period.size()];
  auto alone = [&](const models::LinearModel& m) {
    Chain chain(options);
    chain.feedforward().set_initial(std::make_unique<LinearStage>(m));
    return render(chain, program, {Samples{32}, {}, 1}).drive;
  };
  const Eigen::VectorXd a = alone(a_model), b = alone(b_model);
  const double bound = std::max(testing::largest_step(a), testing::largest_step(b));
  // Below the limiter's knee, so the drive is the slot's output; and far enough apart that switching
  // without a crossfade would step further than the bound.
  ASSERT_LT(std::max(a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff()), options.limiter.knee);
  double instant_switch = 0.0;
  for (Eigen::Index k = 1; k < a.size(); ++k) {
    instant_switch = std::max({instant_switch, std::abs(b[k] - a[k - 1]), std::abs(a[k] - b[k - 1])});
  }
  ASSERT_GT(instant_switch, 1.2 * bound);

  created = destroyed = 0;
  double largest = 0.0, last = 0.0;
  bool started = false;
  {
    Chain chain(options);
    chain.feedforward().set_initial(std::make_unique<CountedLinearStage>(a_model));
    VirtualBackendOptions o;
    o.block = Samples{32};
    o.pacing = Pacing::as_fast_as_possible;
    o.program = period;
    o.plant = models::plant_preset("linear");
    o.plant.oversample = 4;  // the plant only closes the loop here: a coarse integrator keeps the test fast
    o.on_block = [&](const BlockView& v) {
      for (double d : v.drive) {
        if (started) largest = std::max(largest, std::abs(d - last));
        last = d;
        started = true;
      }
    };
    VirtualBackend backend(chain, std::move(o));
    backend.start();
    dsp::Rng rng(51);
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    for (std::uint64_t i = 0; i < 1000; ++i) {
      std::this_thread::sleep_for(std::chrono::microseconds(rng.below(200)));
      chain.feedforward().install(std::make_unique<CountedLinearStage>(i % 2 == 0 ? b_model : a_model));
      // The next install only once this one was taken over, so none is replaced while pending.
      while (chain.metrics().swaps() < i + 1 && std::chrono::steady_clock::now() < give_up) {
        std::this_thread::yield();
      }
    }
    while (!chain.feedforward().idle() && std::chrono::steady_clock::now() < give_up) std::this_thread::yield();
    backend.stop();
    chain.collect_retired();
    const MetricsSnapshot s = chain.metrics().snapshot();
    EXPECT_EQ(s.swaps, 1000u);
    EXPECT_EQ(s.faults, 0u);
    EXPECT_EQ(created, 1001);
    EXPECT_EQ(destroyed, 1000) << "every retired stage is freed by the control thread";
    EXPECT_GT(backend.blocks(), 2000u);
  }
  EXPECT_EQ(destroyed, 1001);
  EXPECT_LE(largest, bound * (1 + 1e-12)) << "largest step " << largest << ", bound " << bound;
}

// Real-time pacing of the periodic program into the linear plant, `block` samples (at 3 kHz) a block.
VirtualBackendOptions paced_options(int block) {
  VirtualBackendOptions o;
  o.block = Samples{block};
  o.pacing = Pacing::real_time;
  o.program = periodic_program();
  o.plant = models::plant_preset("linear");
  return o;
}

TEST(VirtualBackend, RealTimePacingTakesTheBlocksTime) {
  Chain chain(ChainOptions{});
  VirtualBackendOptions o = paced_options(30);  // 10 ms
  VirtualBackend backend(chain, std::move(o));
  const auto t0 = std::chrono::steady_clock::now();
  backend.start();
  while (backend.blocks() < 10) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  backend.stop();
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(elapsed, 0.09);  // 10 blocks of 10 ms, the first one at once
  // Every paced block went through the chain whole (how fast is measured in bench/, not asserted here).
  const MetricsSnapshot s = chain.metrics().snapshot();
  EXPECT_EQ(s.blocks, backend.blocks());
  EXPECT_EQ(s.samples, 30 * s.blocks);
}

// What one stall did: the whole run's figures, and the xruns counted for the stalled block alone.
struct StallOutcome {
  MetricsSnapshot run;                    ///< every figure of the run
  std::uint64_t stalled_block_xruns = 0;  ///< xruns recorded between the stalled block and the next
};

// A block late by less than the buffer's slack is no xrun; one later than that is. The audio thread is
// held up once, from on_block (a test's liberty: real callbacks must not wait), by 1.5 or 3 periods. The
// backend counts a block's xrun after its on_block, so the count read at block 3 and again at block 4
// brackets the stalled block's alone: a busy machine (CI runs the sanitizer builds two tests at a time)
// may make other blocks late too, and with no slack (one period of buffer) any such block is an xrun.
StallOutcome metrics_after_one_stall(double stall_periods, int buffer_periods) {
  Chain chain(ChainOptions{});
  VirtualBackendOptions o = paced_options(60);  // 20 ms
  o.buffer_periods = buffer_periods;
  const auto stall = std::chrono::duration<double>(stall_periods * 0.020);
  auto xruns_before = std::make_shared<std::atomic<std::uint64_t>>(0);
  auto xruns_after = std::make_shared<std::atomic<std::uint64_t>>(0);
  o.on_block = [stall, &chain, xruns_before, xruns_after](const BlockView& b) {
    if (b.index == 3) {
      xruns_before->store(chain.metrics().xruns());
      std::this_thread::sleep_for(stall);
    }
    if (b.index == 4) xruns_after->store(chain.metrics().xruns());
  };
  VirtualBackend backend(chain, std::move(o));
  backend.start();
  while (backend.blocks() < 10) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  backend.stop();
  return StallOutcome{chain.metrics().snapshot(), xruns_after->load() - xruns_before->load()};
}

TEST(VirtualBackend, ALateBlockIsAnXrunOnlyWhenTheBufferWouldHaveRunDry) {
  EXPECT_EQ(metrics_after_one_stall(3.0, 1).stalled_block_xruns, 1u);
  EXPECT_EQ(metrics_after_one_stall(3.0, 2).stalled_block_xruns, 1u);
  EXPECT_EQ(metrics_after_one_stall(1.5, 1).stalled_block_xruns, 1u);
  EXPECT_EQ(metrics_after_one_stall(1.5, 10).stalled_block_xruns, 0u);
  // The backend's total counts the stalled block's xrun too.
  EXPECT_GE(metrics_after_one_stall(3.0, 2).run.xruns, 1u);
}

TEST(VirtualBackend, HowLateTheLatestBlockWasIsReported) {
  // A stall of 1.5 periods (30 ms) puts the block 30 ms minus its own 20 ms period behind: at least 10 ms
  // (a lower bound: the machine can only add to it), well within a buffer of 10 periods (180 ms of slack: a
  // loaded machine, or a sanitizer's, adds tens of milliseconds to the stall), so no xrun.
  const StallOutcome m = metrics_after_one_stall(1.5, 10);
  EXPECT_GE(m.run.max_late_ns, 10e6);
  EXPECT_EQ(m.stalled_block_xruns, 0u);
}

// Whether this system lets a thread of this process run under SCHED_FIFO (asked on a throwaway thread).
bool system_grants_fifo() {
  bool granted = false;
  std::thread probe([&granted] {
    sched_param param{};
    param.sched_priority = 5;
    granted = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0;
  });
  probe.join();
  return granted;
}

// The scheduling policy the audio thread runs under, read from inside it, with and without a priority.
TEST(VirtualBackend, TheAudioThreadRunsUnderTheRealTimePolicyWhenTheSystemGrantsIt) {
  const bool granted = system_grants_fifo();
  for (const int priority : {0, 5}) {
    Chain chain(ChainOptions{});
    VirtualBackendOptions o = paced_options(30);  // 10 ms
    o.realtime_priority = priority;
    auto policy = std::make_shared<std::atomic<int>>(-1);
    o.on_block = [policy](const BlockView&) {
      int p = 0;
      sched_param param{};
      pthread_getschedparam(pthread_self(), &p, &param);
      policy->store(p);
    };
    VirtualBackend backend(chain, std::move(o));
    backend.start();
    while (backend.blocks() < 3) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    backend.stop();
    const bool expect_fifo = priority > 0 && granted;
    EXPECT_EQ(backend.realtime(), expect_fifo) << "priority " << priority;
    EXPECT_EQ(policy->load(), expect_fifo ? SCHED_FIFO : SCHED_OTHER) << "priority " << priority;
  }
}

}  // namespace
}  // namespace panelbass::engine

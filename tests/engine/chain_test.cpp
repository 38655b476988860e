// The chain and its safety limiter: the soft-limit curve, a drive that never leaves [−1, 1] whatever
// the input (any size, NaN, ±Inf), and the fall-back to band-pass only — checked against the stages
// evaluated directly in the test — on a non-finite value or a drive pinned at the rails.
#include "engine/chain.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <stdexcept>
#include <vector>

#include "dsp/butterworth.h"
#include "dsp/random.h"
#include "engine/safety_limiter.h"
#include "tests/engine/engine_test_models.h"
#include "tests/support/model_stages.h"

namespace panelbass::engine {
namespace {

using testing::kFs;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Processes `program` in blocks of `block`.
Eigen::VectorXd run(Chain& chain, const Eigen::VectorXd& program, Eigen::Index block) {
  Eigen::VectorXd drive(program.size());
  for (Eigen::Index pos = 0; pos < program.size(); pos += block) {
    const Eigen::Index n = std::min(block, program.size() - pos);
    chain.process_block({program.data() + pos, static_cast<std::size_t>(n)},
                        {drive.data() + pos, static_cast<std::size_t>(n)});
  }
  return drive;
}

TEST(SoftLimit, IsTheIdentityBelowTheKneeAndBoundedContinuousAndNonExpansiveAbove) {
  const double knee = 0.8;
  double previous = soft_limit(-50.0, knee);
  for (double v = -50.0; v <= 50.0; v += 1e-3) {
    const double d = soft_limit(v, knee);
    EXPECT_DOUBLE_EQ(d, testing::reference_soft_limit(v, knee));
    ASSERT_LE(std::abs(d), 1.0);
    ASSERT_GE(d, previous);                      // monotone
    ASSERT_LE(d - previous, 1e-3 * (1 + 1e-9));  // slope ≤ 1
    previous = d;
  }
  EXPECT_EQ(soft_limit(0.5, knee), 0.5);
  EXPECT_EQ(soft_limit(1e300, knee), 1.0);
  EXPECT_EQ(soft_limit(-kInf, knee), 0.0);
  EXPECT_EQ(soft_limit(kNaN, knee), 0.0);
}

TEST(SafetyLimiter, TripsWhenPinnedLongerThanAllowed) {
  SafetyLimiter limiter({0.8, 1.0, Samples{10}});
  for (int k = 0; k < 10; ++k) limiter.process(2.0);
  EXPECT_EQ(limiter.take_trip(), Fault::none);
  limiter.process(0.5);  // leaving the rails starts the count afresh
  for (int k = 0; k < 10; ++k) limiter.process(-1.0);
  EXPECT_EQ(limiter.take_trip(), Fault::none);
  limiter.process(-1.0);
  EXPECT_EQ(limiter.take_trip(), Fault::pinned);
  EXPECT_THROW(SafetyLimiter({1.0, 1.0, Samples{10}}), std::invalid_argument);
}

TEST(Chain, TheDriveNeverLeavesTheUnitRangeWhateverTheInput) {
  ChainOptions options;
  options.spec.max_block = 256;
  dsp::Rng rng(31);
  for (bool narx : {false, true}) {
    for (double amplitude : {1e-3, 1.0, 1e3, 1e150, 1e300}) {
      for (bool non_finite : {false, true}) {
        Chain chain(options);
        chain.feedforward().set_initial(std::make_unique<LinearStage>(testing::gain_model(40.0)));
        if (narx) chain.feedback().set_initial(std::make_unique<NarxStage>(testing::example_narx(32)));
        std::vector<double> program(3000), drive(3000);
        for (double& x : program) {
          x = rng.uniform(-amplitude, amplitude);
          if (non_finite && rng.below(50) == 0) x = std::array{kNaN, kInf, -kInf}[rng.below(3)];
        }
        for (std::size_t pos = 0; pos < program.size();) {
          const std::size_t n = std::min<std::size_t>(1 + rng.below(256), program.size() - pos);
          chain.process_block({program.data() + pos, n}, {drive.data() + pos, n});
          if (rng.below(10) == 0) chain.clear_fault();  // the fault comes back as often as it is cleared
          pos += n;
        }
        for (double d : drive) {
          ASSERT_TRUE(std::isfinite(d) && std::abs(d) <= 1.0) << d << " at amplitude " << amplitude;
        }
        // A NaN or an infinity always faults; a loud gain pins the drive unless the (bounded) NARX
        // stage follows it.
        const std::uint64_t faults = chain.metrics().snapshot().faults;
        if (non_finite || (!narx && amplitude >= 1e3)) {
          EXPECT_GE(faults, 1u) << "amplitude " << amplitude << (narx ? " with NARX" : "");
        }
        if (!non_finite && amplitude == 1e-3) {
          EXPECT_EQ(faults, 0u);
        }
      }
    }
  }
}

// The thesis's NARX size (NN 17-17-1, na = nb = 8) with random weights from `seed`, scaled output ×0.5.
models::NarxModel thesis_narx(std::uint64_t seed) {
  models::NarxModel m = models::NarxModel::with_structure(models::NarxStructure{}, {0.0, 1.0, 0.0, 0.5}, kFs);
  m.net.initialize(1.0, seed);
  return m;
}

TEST(Chain, TheFullChainIsItsStagesRunOneAfterAnotherOnTheWholeRecord) {
  // Band-pass, linear feedforward, NARX feedback in model mode, limiter: the chain's per-sample path
  // (the NARX stage's kernel and ring histories) against each stage's own whole-record evaluation —
  // SosFilter, LinearModel::simulate, NarxModel::simulate (the straightforward per-sample network) —
  // and the limiter's curve, in blocks of several lengths.
  const models::LinearModel ff = testing::example_linear();
  const models::NarxModel fb = thesis_narx(91);
  const Eigen::VectorXd program = testing::uniform(6000, 0.5, 92);
  const Eigen::VectorXd band = dsp::SosFilter(dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs)).process(program);
  const Eigen::VectorXd v = fb.simulate(ff.simulate(band));
  ASSERT_GT(v.cwiseAbs().maxCoeff(), 0.05);  // the feedback stage shapes something
  for (Eigen::Index block : {64, 17, 1}) {
    ChainOptions options;
    Chain chain(options);
    chain.feedforward().set_initial(std::make_unique<LinearStage>(ff));
    chain.feedback().set_initial(std::make_unique<NarxStage>(fb, FeedbackSource::model));
    const Eigen::VectorXd drive = run(chain, program, block);
    double worst = 0.0;
    for (Eigen::Index k = 0; k < program.size(); ++k) {
      worst = std::max(worst, std::abs(drive[k] - testing::reference_soft_limit(v[k], options.limiter.knee)));
    }
    EXPECT_LE(worst, 1e-12) << "blocks of " << block;
    EXPECT_EQ(chain.metrics().snapshot().faults, 0u);
  }
}

TEST(Chain, ANonFiniteInputDropsTheChainToBandPassOnly) {
  ChainOptions options;
  Chain chain(options);
  const models::LinearModel ff = testing::example_linear();
  chain.feedforward().set_initial(std::make_unique<LinearStage>(ff));
  Eigen::VectorXd program = testing::uniform(600, 0.5, 33);
  program[250] = kNaN;
  const Eigen::VectorXd drive = run(chain, program, 64);

  // Directly: band-pass of the input with the NaN read as 0; the linear stage until the NaN; band-pass
  // alone afterwards; the limiter's curve throughout.
  Eigen::VectorXd cleaned = program;
  cleaned[250] = 0.0;
  const Eigen::VectorXd band = dsp::SosFilter(dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs)).process(cleaned);
  const Eigen::VectorXd shaped = ff.simulate(band.head(250));
  for (Eigen::Index k = 0; k < program.size(); ++k) {
    const double v = k < 250 ? shaped[k] : band[k];
    ASSERT_NEAR(drive[k], testing::reference_soft_limit(v, options.limiter.knee), 1e-12) << k;
  }
  const MetricsSnapshot s = chain.metrics().snapshot();
  EXPECT_EQ(s.faults, 1u);
  EXPECT_EQ(s.last_fault, Fault::non_finite_input);
  EXPECT_TRUE(s.in_fault);
}

TEST(Chain, ADrivePinnedAtTheRailsDropsTheChainUntilTheFaultIsCleared) {
  ChainOptions options;
  options.limiter.max_pinned = Samples{3};
  Chain chain(options);
  chain.feedforward().set_initial(std::make_unique<LinearStage>(testing::gain_model(8.0)));
  const Eigen::VectorXd program = testing::uniform(900, 0.5, 34);
  const Eigen::VectorXd band = dsp::SosFilter(dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs)).process(program);
  // Where the direct evaluation first has more than 3 consecutive samples with |8·band| ≥ 1.
  Eigen::Index trip = -1;
  for (Eigen::Index k = 0, run_length = 0; k < band.size() && trip < 0; ++k) {
    run_length = std::abs(8.0 * band[k]) >= 1.0 ? run_length + 1 : 0;
    if (run_length > 3) trip = k;
  }
  ASSERT_GT(trip, 0);
  ASSERT_LT(trip, 600);

  const Eigen::VectorXd first = run(chain, program.head(600), 50);
  for (Eigen::Index k = 0; k < 600; ++k) {
    const double v = k <= trip ? 8.0 * band[k] : band[k];
    ASSERT_NEAR(first[k], testing::reference_soft_limit(v, options.limiter.knee), 1e-12) << k;
  }
  EXPECT_EQ(chain.metrics().snapshot().last_fault, Fault::pinned);
  EXPECT_TRUE(chain.in_fault());

  // Cleared: the next block runs the whole chain again (a pure gain has no state to reset).
  chain.clear_fault();
  const Eigen::VectorXd second = run(chain, program.segment(600, 2), 2);
  EXPECT_FALSE(chain.in_fault());
  for (Eigen::Index k = 0; k < 2; ++k) {
    EXPECT_NEAR(second[k], testing::reference_soft_limit(8.0 * band[600 + k], options.limiter.knee), 1e-12);
  }
}

// The same chain twice: one run block by block as process_block(program, drive) runs it (stage by stage
// over a block whenever it can), the other through the sensor overload with a sensor that reads 0, which
// runs every sample through the whole chain in turn (the straightforward path).
struct TwinChains {
  explicit TwinChains(const ChainOptions& options) : blockwise(options), per_sample(options) {}
  // Both chains: `f(chain)` (an install, a bypass, clearing a fault).
  template <class F>
  void both(F&& f) {
    f(blockwise);
    f(per_sample);
  }
  // One block of `program` through both; the largest difference of their drives.
  double block(std::span<const double> program) {
    std::vector<double> a(program.size()), b(program.size());
    blockwise.process_block(program, a);
    per_sample.process_block(program, b, [](double) noexcept { return 0.0; });
    double worst = 0.0;
    for (std::size_t k = 0; k < a.size(); ++k) worst = std::max(worst, std::abs(a[k] - b[k]));
    return worst;
  }
  Chain blockwise, per_sample;
};

TEST(Chain, ABlockRunStageByStageGivesThePerSampleNumbersThroughSwapsBypassesAndFaults) {
  ChainOptions options;
  options.spec.max_block = 64;
  options.slots = {Samples{48}, Samples{256}};
  options.limiter.max_pinned = Samples{3};
  TwinChains chains(options);
  chains.both([](Chain& c) {
    c.feedforward().set_initial(std::make_unique<LinearStage>(testing::example_linear()));
    c.feedback().set_initial(std::make_unique<NarxStage>(testing::example_narx(41)));
  });
  Eigen::VectorXd program = testing::uniform(64 * 60, 0.5, 42);
  program[64 * 20 + 17] = kNaN;  // a non-finite input inside a block
  std::size_t pos = 0;
  double worst = 0.0;
  // Blocks of uneven lengths, with the control thread's work between them.
  for (int block = 0; pos < static_cast<std::size_t>(program.size()); ++block) {
    if (block == 5) {
      chains.both([](Chain& c) { c.feedback().install(std::make_unique<NarxStage>(testing::example_narx(43))); });
    }
    if (block == 12) chains.both([](Chain& c) { c.feedforward().set_bypassed(true); });
    if (block == 16) chains.both([](Chain& c) { c.feedforward().set_bypassed(false); });
    if (block == 30) {
      chains.both([](Chain& c) {
        c.clear_fault();
        // A gain that pins the drive: a fault inside the block run, the slots' history cut at it.
        c.feedforward().install(std::make_unique<LinearStage>(testing::gain_model(30.0)));
        c.feedback().install(std::make_unique<PassThroughStage>());
      });
    }
    if (block == 40) {
      chains.both([](Chain& c) {
        c.feedforward().install(std::make_unique<LinearStage>(testing::example_linear()));
        c.feedback().install(std::make_unique<NarxStage>(testing::example_narx(43)));
        c.clear_fault();
      });
    }
    if (block == 45) {
      // Warmed from the slots' histories, which the two paths must have kept alike.
      chains.both([](Chain& c) { c.feedback().install(std::make_unique<NarxStage>(testing::example_narx(44))); });
    }
    const std::size_t n = std::min<std::size_t>(1 + (block * 37) % 64, static_cast<std::size_t>(program.size()) - pos);
    worst = std::max(worst, chains.block({program.data() + pos, n}));
    pos += n;
  }
  EXPECT_LE(worst, 1e-12);
  const MetricsSnapshot a = chains.blockwise.metrics().snapshot(), b = chains.per_sample.metrics().snapshot();
  // Both faults happened (the scenario did what it says), and the two paths counted alike.
  EXPECT_GE(a.faults, 2u);
  EXPECT_GE(a.swaps, 3u);
  EXPECT_GT(a.limited_samples, 0u);
  EXPECT_EQ(a.faults, b.faults);
  EXPECT_EQ(a.swaps, b.swaps);
  EXPECT_EQ(a.limited_samples, b.limited_samples);
  EXPECT_EQ(a.over_range_samples, b.over_range_samples);
  EXPECT_EQ(a.in_fault, b.in_fault);
}

TEST(Chain, AHugeInputLeavesTheBlockRunsForThePerSamplePathWhereAnOverflowIsCaughtAtOnce) {
  ChainOptions options;
  TwinChains chains(options);
  chains.both([](Chain& c) { c.feedforward().set_initial(std::make_unique<LinearStage>(testing::example_linear())); });
  Eigen::VectorXd program = testing::uniform(640, 0.5, 45);
  program[100] = 1e300;  // finite, but the band-pass's state overflows on it
  double worst = 0.0;
  for (Eigen::Index pos = 0; pos < program.size(); pos += 64) {
    const double d = chains.block({program.data() + pos, 64});
    worst = std::max(worst, std::isnan(d) ? 1.0 : d);
  }
  EXPECT_LE(worst, 1e-12);
  EXPECT_EQ(chains.blockwise.metrics().snapshot().faults, chains.per_sample.metrics().snapshot().faults);
}

TEST(Chain, CountsBlocksAndSamples) {
  Chain chain(ChainOptions{});
  run(chain, testing::uniform(1000, 0.5, 35), 64);
  const MetricsSnapshot s = chain.metrics().snapshot();
  EXPECT_EQ(s.blocks, 16u);
  EXPECT_EQ(s.samples, 1000u);
  EXPECT_GT(s.max_block_ns, 0.0);
  EXPECT_GT(s.load, 0.0);
}

TEST(Chain, RejectsBadOptions) {
  ChainOptions options;
  options.spec.fs = 0.0;
  EXPECT_THROW(Chain{options}, std::invalid_argument);
  options = {};
  options.band_pass.high = Hertz{2000.0};
  EXPECT_THROW(Chain{options}, std::invalid_argument);
  options = {};
  options.limiter.knee = -0.1;
  EXPECT_THROW(Chain{options}, std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::engine

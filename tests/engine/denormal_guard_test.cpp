// Denormals on the audio thread: the guard flushes subnormal results to zero while it lives and puts the thread's
// mode back after; a chain's decaying band-pass tail, which goes subnormal when run without it (checked here with
// the same sections through dsp::SosFilter), gives no subnormal drive sample.
#include "engine/denormal_guard.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "dsp/butterworth.h"
#include "dsp/biquad.h"
#include "engine/chain_file.h"

namespace panelbass::engine {
namespace {

// a·b computed at run time (volatile: not folded by the compiler).
double product(double a, double b) {
  volatile double x = a, y = b;
  return x * y;
}

std::size_t subnormals(const Eigen::VectorXd& x) {
  std::size_t n = 0;
  for (Eigen::Index k = 0; k < x.size(); ++k) n += std::fpclassify(x[k]) == FP_SUBNORMAL ? 1 : 0;
  return n;
}

TEST(ScopedFlushDenormals, FlushesWhileItLivesAndRestoresAfter) {
  ASSERT_EQ(std::fpclassify(product(1e-300, 1e-10)), FP_SUBNORMAL) << "this machine keeps subnormals by default";
  {
    const ScopedFlushDenormals guard;
    EXPECT_EQ(product(1e-300, 1e-10), 0.0);
    EXPECT_EQ(product(1e-300, 1e-7), 1e-307) << "normal numbers are untouched";
  }
  EXPECT_EQ(std::fpclassify(product(1e-300, 1e-10)), FP_SUBNORMAL) << "the thread's mode is put back";
}

TEST(ScopedFlushDenormals, ADecayingBandPassTailLeavesTheChainWithoutSubnormals) {
  ChainConfig config;
  config.fs = 3000.0;
  config.block = 64;
  auto chain = make_chain(config);
  Eigen::VectorXd program = Eigen::VectorXd::Zero(64 * 2000);
  program[0] = 0.5;
  // The same band-pass as plain arithmetic: its tail goes subnormal (else this test could not fail).
  const Eigen::VectorXd tail =
      dsp::SosFilter(dsp::butterworth_band(config.band_pass.design.order, config.band_pass.design.low.value,
                                           config.band_pass.design.high.value, config.fs))
          .process(program);
  ASSERT_GT(subnormals(tail), 0u);
  Eigen::VectorXd drive(program.size());
  for (Eigen::Index k = 0; k < program.size(); k += 64) {
    chain->process_block({program.data() + k, 64}, {drive.data() + k, 64});
  }
  EXPECT_EQ(subnormals(drive), 0u);
  EXPECT_GT(std::abs(drive[1]), 1e-3) << "the impulse went through";
  EXPECT_EQ(chain->metrics().snapshot().faults, 0u);
}

}  // namespace
}  // namespace panelbass::engine

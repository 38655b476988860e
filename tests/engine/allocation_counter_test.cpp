// The real-time rule, proven mechanically (NeuralAmpModelerCore's way): global operator new/delete and
// the malloc family are replaced for the whole engine_tests executable (under ASan and TSan, their
// allocator hooks stand in) and count while this thread has set `counting`. The chain — band-pass, linear
// feedforward, NARX feedback in sensor mode, limiter, the virtual plant in the loop — then processes
// blocks, takes over two new stages (warmed off the audio thread, crossfaded, retired), and one that
// waited behind a crossfade and catches up on the audio thread, falls into and out of its safe bypass,
// and must neither allocate nor free.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>
#include <new>
#include <span>
#include <utility>
#include <vector>

#include "engine/chain.h"
#include "engine/closed_loop.h"
#include "engine/controller_stages.h"
#include "engine/program_player.h"
#include "engine/rate_bridge.h"
#include "models/control/feedback_training.h"
#include "models/control/lq_feedforward.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
#include "tests/engine/engine_test_models.h"
#include "tests/support/model_stages.h"
#include "tests/support/ss_models.h"

namespace {

thread_local bool counting = false;
std::atomic<long> allocations{0};
std::atomic<long> frees{0};

void count_allocation() {
  if (counting) allocations.fetch_add(1, std::memory_order_relaxed);
}
void count_free(void* p) {
  if (counting && p != nullptr) frees.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace

// AddressSanitizer and ThreadSanitizer own malloc and operator new (replacing either breaks their
// start-up, or clashes with clang's static runtime at link time): there the counting goes through their
// allocator hooks, which see every allocation and free of the malloc family and operator new alike.
#if defined(PANELBASS_SANITIZER_RUNTIME)  // the sanitizer build, whose test code itself is not instrumented
#define PANELBASS_SANITIZER_OWNS_MALLOC 1
#elif defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)  // GCC
#define PANELBASS_SANITIZER_OWNS_MALLOC 1
#elif defined(__has_feature)  // clang (14 does not define GCC's macros)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define PANELBASS_SANITIZER_OWNS_MALLOC 1
#endif
#endif

#if defined(PANELBASS_SANITIZER_OWNS_MALLOC)
// The sanitizers' common allocator interface (<sanitizer/allocator_interface.h>, which GCC 12 does not
// ship; its runtimes define the function all the same).
extern "C" int __sanitizer_install_malloc_and_free_hooks(void (*malloc_hook)(const volatile void*, std::size_t),
                                                         void (*free_hook)(const volatile void*));
namespace {
void on_sanitizer_malloc(const volatile void*, std::size_t) { count_allocation(); }
void on_sanitizer_free(const volatile void* p) { count_free(const_cast<void*>(p)); }
// Installed before main, so the first test already counts.
const int hooks_installed = __sanitizer_install_malloc_and_free_hooks(on_sanitizer_malloc, on_sanitizer_free);
}  // namespace
#else
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);
}

// The malloc family, forwarded to glibc's implementation.
extern "C" void* malloc(std::size_t n) noexcept {
  count_allocation();
  return __libc_malloc(n);
}
extern "C" void* calloc(std::size_t count, std::size_t n) noexcept {
  count_allocation();
  return __libc_calloc(count, n);
}
extern "C" void* realloc(void* p, std::size_t n) noexcept {
  count_allocation();
  return __libc_realloc(p, n);
}
extern "C" void* aligned_alloc(std::size_t align, std::size_t n) noexcept {
  count_allocation();
  return __libc_memalign(align, n);
}
extern "C" void* memalign(std::size_t align, std::size_t n) noexcept {
  count_allocation();
  return __libc_memalign(align, n);
}
extern "C" int posix_memalign(void** out, std::size_t align, std::size_t n) noexcept {
  count_allocation();
  *out = __libc_memalign(align, n);
  return *out != nullptr ? 0 : 12;  // ENOMEM
}
extern "C" void free(void* p) noexcept {
  count_free(p);
  __libc_free(p);
}

// operator new/delete in every form, counted once each (glibc's own allocators do not count again).
namespace {
void* counted_new(std::size_t n) {
  count_allocation();
  if (void* p = __libc_malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void* counted_new(std::size_t n, std::align_val_t align) {
  count_allocation();
  if (void* p = __libc_memalign(static_cast<std::size_t>(align), n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void* counted_new_nothrow(std::size_t n) noexcept {
  count_allocation();
  return __libc_malloc(n == 0 ? 1 : n);
}
void counted_delete(void* p) noexcept {
  count_free(p);
  __libc_free(p);
}
}  // namespace

void* operator new(std::size_t n) { return counted_new(n); }
void* operator new[](std::size_t n) { return counted_new(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept { return counted_new_nothrow(n); }
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept { return counted_new_nothrow(n); }
void* operator new(std::size_t n, std::align_val_t a) { return counted_new(n, a); }
void* operator new[](std::size_t n, std::align_val_t a) { return counted_new(n, a); }
void operator delete(void* p) noexcept { counted_delete(p); }
void operator delete[](void* p) noexcept { counted_delete(p); }
void operator delete(void* p, std::size_t) noexcept { counted_delete(p); }
void operator delete[](void* p, std::size_t) noexcept { counted_delete(p); }
void operator delete(void* p, std::align_val_t) noexcept { counted_delete(p); }
void operator delete[](void* p, std::align_val_t) noexcept { counted_delete(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { counted_delete(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { counted_delete(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { counted_delete(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { counted_delete(p); }
#endif

namespace panelbass::engine {
namespace {

/// Counts allocations and frees on this thread while it lives.
struct Counting {
  Counting() {
    allocations = 0;
    frees = 0;
    counting = true;
  }
  ~Counting() { counting = false; }
};

/// The allocations and frees on this thread while `work` runs.
struct Counted {
  long allocations = 0, frees = 0;
};
template <class Work>
Counted count_during(Work&& work) {
  Counting c;
  work();
  return {allocations, frees};
}

// Keeps the compiler from proving a pointer unused.
void* volatile sink = nullptr;

TEST(AllocationCounter, SeesAllocationsAndFrees) {
  long seen_allocations = 0, seen_frees = 0;
  {
    Counting c;
    auto* v = new std::vector<double>(100);
    sink = v;
    delete v;
    seen_allocations = allocations;
    seen_frees = frees;
  }
#if defined(PANELBASS_SANITIZER_OWNS_MALLOC)
  ASSERT_NE(hooks_installed, 0) << "the sanitizer took no allocator hooks: nothing below would be counted";
#endif
  EXPECT_GE(seen_allocations, 2);
  EXPECT_GE(seen_frees, 2);
  void* (*volatile allocate)(std::size_t) = std::malloc;
  {
    Counting c;
    sink = allocate(64);
    seen_allocations = allocations;
  }
  std::free(sink);
  EXPECT_EQ(seen_allocations, 1);
}

/// `chain` closed over the panel-exciter plant (noise seed 3), fed `program` 64 samples a block.
class ClosedLoopBlocks {
 public:
  ClosedLoopBlocks(Chain& chain, Eigen::VectorXd program)
      : chain_(chain), plant_(models::plant_preset("panel-exciter"), 3), program_(std::move(program)) {}
  /// The next `blocks` blocks of the program.
  void operator()(int blocks) {
    for (int b = 0; b < blocks; ++b, ++block_) run({program_.data() + 64 * block_, 64});
  }
  /// One block of `program` (64 samples) instead of the program's next.
  void run(std::span<const double> program) { process_closed_loop(chain_, plant_, program, drive_, measured_); }

 private:
  Chain& chain_;
  models::VirtualTransducer plant_;
  Eigen::VectorXd program_;
  std::vector<double> drive_ = std::vector<double>(64), measured_ = std::vector<double>(64);
  int block_ = 0;
};

// The virtual transducer with every structure the presets do not use — an L2R2 branch, creep, Rms(v), a microphone
// with a fractional delay, pink and white sensor noise — steps on the audio thread (panelbass transducer --jack)
// without allocating or freeing.
TEST(AllocationCounter, TheVirtualTransducerWithItsNewStructuresStepsWithoutAllocating) {
  models::PlantConfig p = models::plant_preset("panel-exciter");
  p.eddy = {4e-4, 2.5};
  p.creep = {0.1, 0.02};
  p.nonlinear.damping.enabled = true;
  p.nonlinear.damping.r2_per_m2ps2 = 0.5;
  p.sensor.kind = models::SensorKind::microphone;
  p.sensor.delay_samples = 3.7;
  p.sensor.coloured_noise = {models::NoiseShape::pink, 0.02, 10.0, 1.0, 1500.0};
  p.oversample = std::max(p.oversample, models::required_oversample(p));
  models::VirtualTransducer plant(p, 3);
  double sum = 0.0;
  const Counted counted = count_during([&] {
    for (int k = 0; k < 2000; ++k) sum += plant.step(0.4 * std::sin(0.1 * k)).y;
    plant.reset();
  });
  EXPECT_TRUE(std::isfinite(sum));
  EXPECT_EQ(counted.allocations, 0);
  EXPECT_EQ(counted.frees, 0);
}

// A new program (PUT /api/program) is taken over, faded and its predecessor retired on the audio thread
// without allocating or freeing; the control thread frees the retired buffers.
TEST(AllocationCounter, TheProgramPlayerSwapsProgramsWithoutAllocatingOrFreeing) {
  ProgramPlayer player(std::vector<double>(300, 0.1), true, 50);
  std::vector<double> block(64);
  double sum = 0.0;
  for (int swap = 0; swap < 3; ++swap) {
    player.install(std::vector<double>(200 + 10 * swap, 0.2));
    const Counted counted = count_during([&] {
      for (int b = 0; b < 4; ++b) {
        player.fill(block);
        sum += block.back();
      }
    });
    EXPECT_EQ(counted.allocations, 0) << swap;
    EXPECT_EQ(counted.frees, 0) << swap;
    EXPECT_TRUE(player.idle());
    EXPECT_EQ(player.collect_retired(), 1u);
  }
  EXPECT_TRUE(std::isfinite(sum));
}

TEST(AllocationCounter, TheChainProcessesSwapsAndFaultsWithoutAllocatingOrFreeing) {
  ChainOptions options;
  options.spec.max_block = 64;
  options.slots = {Samples{48}, Samples{256}};
  Chain chain(options);
  chain.feedforward().set_initial(std::make_unique<LinearStage>(testing::example_linear()));
  chain.feedback().set_initial(std::make_unique<NarxStage>(testing::example_narx(61), FeedbackSource::sensor));
  ClosedLoopBlocks process(chain, testing::uniform(64 * 40, 0.5, 62));
  process(8);  // warm: history filled, every lazily sized buffer sized

  // Control side (may allocate): two new stages and a bypass.
  const models::LinearModel next_ff = testing::resonant_linear(0.9, 0.3, Eigen::Vector2d(1, 0.5), 1);
  chain.feedforward().install(std::make_unique<LinearStage>(next_ff));
  chain.feedback().install(std::make_unique<NarxStage>(testing::example_narx(63), FeedbackSource::sensor));
  long after_swaps = 0, frees_after_swaps = 0;
  {
    Counting c;
    process(4);  // take-over, warm-up from history, crossfade, retirement
    chain.band_pass().set_bypassed(true);
    process(2);
    chain.band_pass().set_bypassed(false);
    process(2);
    after_swaps = allocations;
    frees_after_swaps = frees;
  }
  EXPECT_EQ(after_swaps, 0);
  EXPECT_EQ(frees_after_swaps, 0);
  EXPECT_EQ(chain.metrics().snapshot().swaps, 2u);
  EXPECT_EQ(chain.collect_retired(), 2u);

  // A fault and its clearing.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> bad(64, nan);
  long during_fault = 0, frees_during_fault = 0;
  {
    Counting c;
    process.run(bad);
    process(2);
    chain.clear_fault();
    process(2);
    during_fault = allocations;
    frees_during_fault = frees;
  }
  EXPECT_EQ(during_fault, 0);
  EXPECT_EQ(frees_during_fault, 0);
  EXPECT_EQ(chain.metrics().snapshot().faults, 1u);
  EXPECT_FALSE(chain.in_fault());
}

TEST(AllocationCounter, TheChainsBlockRunsAllocateNothingThroughSwapsAndFaults) {
  // Model mode without a plant: process_block(program, drive) runs the stages block by block whenever no
  // swap, fade or fault is under way, and sample by sample otherwise.
  ChainOptions options;
  options.spec.max_block = 64;
  options.slots = {Samples{48}, Samples{256}};
  Chain chain(options);
  chain.feedforward().set_initial(std::make_unique<LinearStage>(testing::example_linear()));
  chain.feedback().set_initial(std::make_unique<NarxStage>(testing::example_narx(71)));
  const Eigen::VectorXd program = testing::uniform(64 * 40, 0.5, 72);
  std::vector<double> drive(64);
  int block = 0;
  auto process = [&](int blocks) {
    for (int b = 0; b < blocks; ++b, ++block) {
      chain.process_block({program.data() + 64 * (block % 40), 64}, drive);
    }
  };
  process(8);
  chain.feedback().install(std::make_unique<NarxStage>(testing::example_narx(73)));
  std::vector<double> bad(64, 0.1);
  bad[30] = std::numeric_limits<double>::quiet_NaN();
  const Counted counted = count_during([&] {
    process(4);  // take-over, crossfade, then block runs again
    chain.feedforward().set_bypassed(true);
    process(3);
    chain.feedforward().set_bypassed(false);
    process(3);
    chain.process_block(bad, drive);  // a fault inside a block run
    process(2);
    chain.clear_fault();
    process(4);
  });
  EXPECT_EQ(counted.allocations, 0);
  EXPECT_EQ(counted.frees, 0);
  EXPECT_EQ(chain.metrics().snapshot().swaps, 1u);
  EXPECT_EQ(chain.metrics().snapshot().faults, 1u);
  EXPECT_FALSE(chain.in_fault());
}

TEST(AllocationCounter, AStageCaughtUpOverBlocksOnTheAudioThreadAllocatesNothing) {
  ChainOptions options;
  options.spec.max_block = 64;
  options.slots = {Samples{200}, Samples{256}};
  Chain chain(options);
  chain.feedback().set_initial(std::make_unique<NarxStage>(testing::example_narx(71), FeedbackSource::sensor));
  ClosedLoopBlocks process(chain, testing::uniform(64 * 40, 0.5, 72));
  process(8);
  chain.feedback().install(std::make_unique<NarxStage>(testing::example_narx(73), FeedbackSource::sensor));
  process(1);  // taken over; its 200-sample crossfade runs
  chain.feedback().install(std::make_unique<NarxStage>(testing::example_narx(74), FeedbackSource::sensor));
  const Counted counted = count_during([&] {
    process(30);  // the second waits out the fade, catches up block by block, crossfades
  });
  EXPECT_EQ(counted.allocations, 0);
  EXPECT_EQ(counted.frees, 0);
  EXPECT_EQ(chain.metrics().snapshot().swaps, 2u);
  EXPECT_TRUE(chain.feedback().idle());
  EXPECT_EQ(chain.collect_retired(), 2u);
}

TEST(AllocationCounter, TheControllerStagesSwapAndRunWithoutAllocatingOrFreeing) {
  ChainOptions options;
  options.spec.max_block = 64;
  options.slots = {Samples{48}, Samples{256}};
  Chain chain(options);
  const models::LqFeedforward ff = models::design_lq(testing::example_linear(), {1e-3, 20.0});
  models::FeedbackStructure structure;
  structure.hidden = {6};
  models::NeuralFeedback fb = models::NeuralFeedback::with_structure(structure, testing::example_narx(71));
  models::initialize_feedback(fb, 72, 1.0);
  chain.feedforward().set_initial(std::make_unique<StateSpaceStage>(ff.controller(), ff.fs));
  chain.feedback().set_initial(std::make_unique<NeuralFeedbackStage>(fb, FeedbackSource::sensor));
  ClosedLoopBlocks process(chain, testing::uniform(64 * 30, 0.3, 73));
  process(8);
  // new controllers of both kinds (the feedback one now in model mode: its own plant model runs)
  chain.feedforward().install(std::make_unique<StateSpaceStage>(ff.controller(), ff.fs));
  chain.feedback().install(std::make_unique<NeuralFeedbackStage>(fb, FeedbackSource::model));
  const Counted counted = count_during([&] {
    process(6);
  });
  EXPECT_EQ(counted.allocations, 0);
  EXPECT_EQ(counted.frees, 0);
  EXPECT_EQ(chain.metrics().snapshot().swaps, 2u);
  EXPECT_EQ(chain.collect_retired(), 2u);
}

// The neural feedback controller with a neural state-space plant model (its tanh layer and polynomial both
// nonzero) in model mode: the plant model steps on the audio thread, and a new controller takes over.
TEST(AllocationCounter, TheNeuralFeedbackStageRunsAStateSpacePlantModelWithoutAllocatingOrFreeing) {
  ChainOptions options;
  options.spec.max_block = 64;
  options.slots = {Samples{48}, Samples{256}};
  Chain chain(options);
  const double fs = models::plant_preset("panel-exciter").fs;
  models::FeedbackStructure structure;
  structure.hidden = {6};
  models::NeuralFeedback fb = models::NeuralFeedback::with_structure(
      structure, testing_support::resonant_ss(100.0, fs, 0.1, 0.05, 0.5, 0.05, 0.02, models::Scaling{}, 81));
  models::initialize_feedback(fb, 82, 1.0);
  chain.feedback().set_initial(std::make_unique<NeuralFeedbackStage>(fb, FeedbackSource::model));
  ClosedLoopBlocks process(chain, testing::uniform(64 * 20, 0.3, 83));
  process(4);
  chain.feedback().install(std::make_unique<NeuralFeedbackStage>(fb, FeedbackSource::model));
  const Counted counted = count_during([&] {
    process(6);
  });
  EXPECT_EQ(counted.allocations, 0);
  EXPECT_EQ(counted.frees, 0);
  EXPECT_EQ(chain.metrics().snapshot().swaps, 1u);
  EXPECT_EQ(chain.collect_retired(), 1u);
}

TEST(AllocationCounter, TheRateBridgeAndTheChainRunOddPeriodsWithoutAllocating) {
  for (const auto& [fs, quality] : {std::pair{44100.0, ResampleQuality::low_latency}, std::pair{48000.0, ResampleQuality::low_latency},
                                   std::pair{44100.0, ResampleQuality::fastest}, std::pair{48000.0, ResampleQuality::fastest}}) {
    RateBridgeOptions bo;
    bo.device_rate = Hertz{fs};
    bo.quality = quality;
    bo.max_period = Samples{256};
    bo.input_channels = 2;
    RateBridge bridge(bo);
    ChainOptions co;
    co.spec = {3000.0, 64};
    Chain chain(co);
    std::vector<double> a(256, 0.1), b(256, 0.2), out(256);
    const std::size_t sizes[] = {1, 13, 64, 127, 250, 7, 64, 199, 33, 256};
    auto run = [&](int periods) {
      for (int i = 0; i < periods; ++i) {
        const std::size_t n = sizes[i % 10];
        const std::span<const double> in[2] = {{a.data(), n}, {b.data(), n}};
        bridge.process(std::span<const std::span<const double>>(in, 2), std::span<double>(out.data(), n),
                       [&](std::span<const std::span<const double>> m, std::span<double> y) {
                         std::size_t k = 0;
                         chain.process_block(m[0], y, [&](double) noexcept { return m[1][k++]; });
                       });
      }
    };
    run(50);
    long seen = 0, freed = 0;
    {
      Counting c;
      run(2000);
      seen = allocations;
      freed = frees;
    }
    EXPECT_EQ(seen, 0) << fs;
    EXPECT_EQ(freed, 0) << fs;
  }
}

}  // namespace
}  // namespace panelbass::engine

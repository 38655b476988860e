#pragma once
// Processing stages of the engine's chain, in JUCE's shape: prepare() sizes and allocates (and may
// throw), process() is noexcept and touches only what prepare() made, reset() clears the state.
// A stage's parameters (the model) and its state are separate, so a new stage can be warmed from the
// recent history before it takes over.

#include <Eigen/Core>
#include <cstdint>
#include <span>

#include "dsp/biquad.h"
#include "engine/metrics.h"
#include "models/linear/linear_model.h"

namespace panelbass::engine {

/// A frequency in Hz.
struct Hertz {
  double value = 0.0;
};

/// A duration or a length in samples.
struct Samples {
  int value = 0;
};

/// What a stage is prepared for.
struct ProcessSpec {
  double fs = 3000.0;   ///< sample rate the chain runs at, Hz
  int max_block = 1024; ///< longest block process_block() will be given
};

/// What a stage that limits its own output asked for before that limit, since it was last asked.
struct StageDemand {
  std::uint64_t over_range = 0;  ///< samples whose unlimited output was at or beyond full scale (|·| ≥ 1)
  double peak = 0.0;             ///< the largest |unlimited output|
};

/// One stage of the chain. Every method but prepare() and the constructor is for the thread that owns the
/// stage: the control thread until ModelSlot::install() publishes it (which warms it there), then the
/// audio thread.
class Stage {
 public:
  virtual ~Stage() = default;

  /// Sizes and allocates everything process() touches; throws std::invalid_argument naming the problem.
  virtual void prepare(const ProcessSpec& spec) = 0;

  /// One sample in, one sample out; allocation-free.
  virtual double process(double x) noexcept = 0;

  /// The plant's measured output for the sample just processed (sensor mode); ignored by default.
  virtual void observe(double measured) noexcept { (void)measured; }

  /// Back to rest.
  virtual void reset() noexcept = 0;
  /// A fault the stage raised since the last call (e.g. its sensor went silent), Fault::none if none;
  /// the chain polls it once per block and records it without bypassing anything.
  virtual Fault take_fault() noexcept { return Fault::none; }
  /// What the stage asked for before its own output limit since the last call, and clears it (nothing for a
  /// stage without one); the chain adds it to its needs-more-drive count once per block.
  virtual StageDemand take_demand() noexcept { return {}; }

  /// A block: out[k] = process(in[k]); `out` as long as `in` (it may be `in` itself). A stage overrides it
  /// with a loop that makes no call per sample, computing the same numbers within rounding.
  virtual void process_block(std::span<const double> in, std::span<double> out) noexcept;

  /// True when observe() changes what the stage computes (it reads the plant's output); then a block runs
  /// as process() and observe() sample by sample. False for a stage that ignores observe().
  virtual bool observes() const noexcept { return true; }

  /// From rest, runs the stage over recent history (inputs and measured outputs, oldest first) so its
  /// state is what it would be had it been running all along; returns its output for the last sample
  /// of the history (0 for none).
  double warm_up(std::span<const double> input, std::span<const double> measured) noexcept;

  /// An identifier shown in the metrics (0 = none), e.g. the model store's id.
  std::uint64_t id() const { return id_; }
  /// Sets the identifier; before the stage is installed.
  void set_id(std::uint64_t id) { id_ = id; }

 private:
  std::uint64_t id_ = 0;
};

/// Output = input.
class PassThroughStage final : public Stage {
 public:
  /// Nothing to size.
  void prepare(const ProcessSpec&) override {}
  /// Returns x.
  double process(double x) noexcept override { return x; }
  /// Copies the block.
  void process_block(std::span<const double> in, std::span<double> out) noexcept override;
  /// Ignores the plant.
  bool observes() const noexcept override { return false; }
  /// No state.
  void reset() noexcept override {}
};

/// Corners and order of the band-pass.
struct BandPassDesign {
  Hertz low{20.0};     ///< high-pass corner (-3 dB); 0 = no high-pass (low-pass only, the thesis's "0–1200 Hz")
  Hertz high{1200.0};  ///< low-pass corner (-3 dB)
  int order = 2;       ///< order of each of the high-pass and the low-pass
};

/// The chain's band-pass: a Butterworth high-pass and low-pass in second-order sections.
class BandPassStage final : public Stage {
 public:
  /// A band-pass of `design`, designed at the rate prepare() is given.
  explicit BandPassStage(BandPassDesign design = {});
  /// Designs the sections at spec.fs; throws unless 0 ≤ low < high < fs/2 (low = 0: low-pass only).
  void prepare(const ProcessSpec& spec) override;
  /// Filters one sample.
  double process(double x) noexcept override { return filter_.process(x); }
  /// Filters a block (SosFilter::process_block: the same numbers as sample by sample).
  void process_block(std::span<const double> in, std::span<double> out) noexcept override {
    filter_.process_block(in, out);
  }
  /// Ignores the plant.
  bool observes() const noexcept override { return false; }
  /// Clears the filter state.
  void reset() noexcept override { filter_.reset(); }
  /// The design.
  const BandPassDesign& design() const { return design_; }

 private:
  BandPassDesign design_;
  dsp::SosFilter filter_;
};

/// The most states a stage runs (a StateSpaceStage's, and a linear model's realisation, which api/ validates
/// against it): a dense state space costs O(n²) per sample and a realisation of order max(na, nb + nk) O(n³)
/// when it is prepared, so a long pure delay would stall a model swap; identified models stay far below this.
inline constexpr Eigen::Index kMaxStageStates = 64;

/// The order of the state space a linear model's realisation has for `tf`: max(na, nb + nk).
Eigen::Index linear_stage_states(const models::TransferFunction& tf);

/// Where a feedback stage takes its past outputs y(k−1..k−na) from.
enum class FeedbackSource {
  model,   ///< its own predictions (free run: no sensor wired)
  sensor,  ///< the measured outputs passed to observe()
};

}  // namespace panelbass::engine

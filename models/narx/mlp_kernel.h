#pragma once
// The MLP of mlp.h prepared for the engine's per-sample path: contiguous column-major weights and a
// vectorised tanh, so one evaluation is a few vector multiply-adds per input and no call per neuron.
// Two code paths, chosen when the kernel is made: the x86-64 baseline (SSE2, what every build emits) and,
// on a CPU that has them, AVX2 with fused multiply-adds (function-level target attributes, so the package
// still runs on any x86-64).

#include <cstddef>
#include <span>
#include <vector>

#include "models/narx/mlp.h"
#include "models/narx/narx_history.h"

namespace panelbass::models {

/// tanh of each entry in place, vectorised: 1 − 2/(e^{2x} + 1) with Eigen's packet exp. Within 1e-15 of
/// std::tanh (absolute), exactly ±1 beyond |x| ≈ 19, NaN for NaN; never allocates.
void tanh_in_place(std::span<double> x) noexcept;

/// The instruction sets a kernel may use.
enum class SimdLevel {
  baseline,  ///< x86-64's SSE2 (or whatever the build targets): always available
  avx2_fma,  ///< AVX2 and FMA, four doubles a vector and fused multiply-adds (only where the CPU has them)
  best,      ///< the best this CPU runs
};

/// True when this CPU runs SimdLevel::avx2_fma code (checked once).
bool avx2_fma_available() noexcept;

/// tanh of each entry in place with the code of `level` (best: the fastest available); the same accuracy
/// as tanh_in_place (within 1e-15 of std::tanh, ±1 far out, NaN kept). `level` must be available.
void tanh_in_place(std::span<double> x, SimdLevel level) noexcept;

namespace detail {
/// One hidden layer's place in an MlpKernel's storage (offsets in doubles).
struct KernelLayer {
  std::size_t inputs = 0, nodes = 0, stride = 0;  ///< stride: nodes rounded up to a multiple of 4
  std::size_t weights = 0, bias = 0, out = 0;     ///< offsets into the weights and the activations
};
/// What one forward pass reads and writes: the layers, the weights (per layer: the weight columns, stride
/// each, then the biases), the activations (stride per layer) and the output node (weights padded with
/// zeros to the last layer's stride, then its bias).
struct KernelView {
  const KernelLayer* layers = nullptr;
  std::size_t layer_count = 0;
  const double* weights = nullptr;
  double* activations = nullptr;
  const double* output = nullptr;
  std::size_t output_inputs = 0;  ///< inputs of the output node (the last width, or the network's inputs)
};
/// The forward pass with AVX2 and FMA (mlp_kernel_avx2.cpp); only where avx2_fma_available().
double forward_avx2_fma(const KernelView& net, std::span<const double> head, std::span<const double> tail) noexcept;
/// MlpKernel::free_run with AVX2 and FMA; only where avx2_fma_available().
void free_run_avx2_fma(const KernelView& net, NarxHistory& history, std::span<const double> u,
                       std::span<double> y) noexcept;
/// tanh_in_place with AVX2 and FMA; only where avx2_fma_available().
void tanh_avx2_fma(std::span<double> x) noexcept;
}  // namespace detail

/// An Mlp prepared for the real-time path: its weights copied once, column by column, into padded
/// contiguous storage, so a layer is a run of vector multiply-adds (one column per input, four nodes at a
/// time) and one vectorised tanh, with no call per neuron and no allocation. Its output is the Mlp's
/// within rounding (a few 1e-16: the sums run in another order, FMA rounds once where the baseline
/// rounds twice, and the tanh is not std::tanh).
class MlpKernel {
 public:
  /// No network: forward() returns 0.
  MlpKernel() = default;
  /// The kernel of `net` (a copy of its weights as they are now), run with the code of `level` (best: the
  /// fastest this CPU has; avx2_fma where the CPU lacks it falls back to the baseline).
  explicit MlpKernel(const Mlp& net, SimdLevel level = SimdLevel::best);
  MlpKernel(const MlpKernel& other) { *this = other; }
  MlpKernel& operator=(const MlpKernel& other);

  /// Number of inputs.
  int inputs() const { return inputs_; }
  /// The code path it runs.
  SimdLevel level() const { return level_; }
  /// F(x) for x = head followed by tail (head.size() + tail.size() == inputs(), which the caller checked
  /// once when it was prepared), so a regressor kept in two histories needs no copy.
  double forward(std::span<const double> head, std::span<const double> tail) noexcept {
    return level_ == SimdLevel::avx2_fma ? detail::forward_avx2_fma(view_, head, tail) : forward_baseline(head, tail);
  }
  /// [5G] A NARX free run over a block, the network's output fed back: for each k, u[k] becomes the newest
  /// input of `history`, y[k] = forward(past outputs, past inputs) and y[k] the newest past output. The same
  /// numbers as that loop of forward() (bit for bit), the feedback kept in registers. `y` as long as `u`
  /// (it may be `u` itself); `history` of a structure whose na + nb + 1 is inputs().
  void free_run(NarxHistory& history, std::span<const double> u, std::span<double> y) noexcept;

 private:
  double forward_baseline(std::span<const double> head, std::span<const double> tail) noexcept;
  void make_view() noexcept;

  int inputs_ = 0;
  SimdLevel level_ = SimdLevel::baseline;
  std::vector<detail::KernelLayer> layers_;
  std::vector<double> weights_;      // per layer: the weight columns (stride each), then the biases
  std::vector<double> activations_;  // per layer: stride node values
  std::vector<double> output_;       // the linear output node's weights (padded to a multiple of 4), then its bias
  detail::KernelView view_{};        // pointers into the vectors above
};

}  // namespace panelbass::models

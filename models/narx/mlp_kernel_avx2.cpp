// MlpKernel's AVX2 + FMA code path: function-level target attributes (no -mavx2 for the file), so nothing
// here runs, and no shared inline code is emitted with these instructions, unless the CPU has them; the
// kernel calls it only where avx2_fma_available().
#include "models/narx/mlp_kernel.h"

#include <algorithm>

#if defined(__x86_64__)
#include <immintrin.h>

#define PANELBASS_AVX2_FMA __attribute__((target("avx2,fma")))

namespace panelbass::models::detail {
namespace {

// tanh of four doubles: tanh(x) = (e^{2x} − 1)/(e^{2x} + 1) with e^{2x} = 2^n·e^r, n = round(2x/ln 2),
// r = 2x − n·ln 2 (ln 2 in two parts, Cody–Waite), and e^r = (Q + P)/(Q − P) with Cephes' rational
// P(r) = r·(p0 r⁴ + p1 r² + p2), Q(r) = q0 r⁶ + q1 r⁴ + q2 r² + q3 (Eigen's pexp), folded into one division:
//   tanh(x) = (2^n (Q + P) − (Q − P)) / (2^n (Q + P) + (Q − P)).
// 2x is clamped to ±40, beyond which tanh rounds to ±1; a NaN is passed through.
PANELBASS_AVX2_FMA inline __m256d tanh4(__m256d x) noexcept {
  const __m256d nan = _mm256_cmp_pd(x, x, _CMP_UNORD_Q);
  const __m256d y = _mm256_min_pd(_mm256_max_pd(_mm256_add_pd(x, x), _mm256_set1_pd(-40.0)), _mm256_set1_pd(40.0));
  const __m256d n = _mm256_round_pd(_mm256_fmadd_pd(y, _mm256_set1_pd(1.4426950408889634073599), _mm256_set1_pd(0.5)),
                                    _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
  __m256d r = _mm256_fnmadd_pd(n, _mm256_set1_pd(0.693145751953125), y);
  r = _mm256_fnmadd_pd(n, _mm256_set1_pd(1.42860682030941723212e-6), r);
  const __m256d r2 = _mm256_mul_pd(r, r);
  __m256d p = _mm256_fmadd_pd(_mm256_set1_pd(1.26177193074810590878e-4), r2, _mm256_set1_pd(3.02994407707441961300e-2));
  p = _mm256_fmadd_pd(p, r2, _mm256_set1_pd(9.99999999999999999910e-1));
  p = _mm256_mul_pd(p, r);
  __m256d q = _mm256_fmadd_pd(_mm256_set1_pd(3.00198505138664455042e-6), r2, _mm256_set1_pd(2.52448340349684104192e-3));
  q = _mm256_fmadd_pd(q, r2, _mm256_set1_pd(2.27265548208155028766e-1));
  q = _mm256_fmadd_pd(q, r2, _mm256_set1_pd(2.00000000000000000009e0));
  // 2^n from n's bits: (n + 1023) << 52, exact for |n| ≤ 58.
  const __m256i bits = _mm256_slli_epi64(_mm256_add_epi64(_mm256_cvtepi32_epi64(_mm256_cvtpd_epi32(n)),
                                                          _mm256_set1_epi64x(1023)), 52);
  const __m256d scaled = _mm256_mul_pd(_mm256_castsi256_pd(bits), _mm256_add_pd(q, p));
  const __m256d below = _mm256_sub_pd(q, p);
  const __m256d t = _mm256_div_pd(_mm256_sub_pd(scaled, below), _mm256_add_pd(scaled, below));
  return _mm256_blendv_pd(t, x, nan);
}

// sum += Σ_j column j's four rows · x[j], columns from `w` on (stride apart), in two interleaved chains so
// the multiply-adds overlap; returns the pointer past the last column read.
PANELBASS_AVX2_FMA inline const double* accumulate(__m256d& sum, __m256d& odd, const double* w, std::size_t stride,
                                                   std::span<const double> x) noexcept {
  std::size_t j = 0;
  for (; j + 1 < x.size(); j += 2) {
    sum = _mm256_fmadd_pd(_mm256_loadu_pd(w), _mm256_set1_pd(x[j]), sum);
    odd = _mm256_fmadd_pd(_mm256_loadu_pd(w + stride), _mm256_set1_pd(x[j + 1]), odd);
    w += 2 * stride;
  }
  if (j < x.size()) {
    sum = _mm256_fmadd_pd(_mm256_loadu_pd(w), _mm256_set1_pd(x[j]), sum);
    w += stride;
  }
  return w;
}

// Σ of the four lanes.
PANELBASS_AVX2_FMA inline double horizontal_sum(__m256d v) noexcept {
  const __m128d pair = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
  return _mm_cvtsd_f64(_mm_add_sd(pair, _mm_unpackhi_pd(pair, pair)));
}

}  // namespace

PANELBASS_AVX2_FMA double forward_avx2_fma(const KernelView& net, std::span<const double> head,
                                           std::span<const double> tail) noexcept {
  const double* out_w = net.output;
  const double out_bias = out_w[(net.output_inputs + 3) / 4 * 4];
  if (net.layer_count == 0) {
    // No hidden layer: F = w_out·x + b_out.
    double f = out_bias;
    for (std::size_t j = 0; j < head.size(); ++j) f += out_w[j] * head[j];
    for (std::size_t j = 0; j < tail.size(); ++j) f += out_w[head.size() + j] * tail[j];
    return f;
  }
  std::span<const double> previous;
  __m256d f4 = _mm256_setzero_pd();
  for (std::size_t l = 0; l < net.layer_count; ++l) {
    const KernelLayer& layer = net.layers[l];
    double* node = net.activations + layer.out;
    const bool last = l + 1 == net.layer_count;
    // [fig 5.6] node_in = W·x + b, node_out = tanh(node_in); four nodes at a time, column by column
    for (std::size_t r = 0; r < layer.stride; r += 4) {
      __m256d sum = _mm256_loadu_pd(net.weights + layer.bias + r);
      __m256d odd = _mm256_setzero_pd();
      const double* w = net.weights + layer.weights + r;
      if (l == 0 && !head.empty()) {
        // head[0] (a NARX's y(k−1), the newest feedback) last: everything else is summed before it is known,
        // so in a free run only one multiply-add lies between one output and the next one's tanh.
        accumulate(sum, odd, w + layer.stride, layer.stride, head.subspan(1));
        accumulate(sum, odd, w + head.size() * layer.stride, layer.stride, tail);
        sum = _mm256_fmadd_pd(_mm256_loadu_pd(w), _mm256_set1_pd(head[0]), _mm256_add_pd(sum, odd));
      } else {
        accumulate(sum, odd, w, layer.stride, l == 0 ? tail : previous);
        sum = _mm256_add_pd(sum, odd);
      }
      const __m256d a = tanh4(sum);
      // The last layer feeds the linear output node directly: F = w_out·a + b_out (padding: w = 0, a = 0).
      if (last) {
        f4 = _mm256_fmadd_pd(_mm256_loadu_pd(out_w + r), a, f4);
      } else {
        _mm256_storeu_pd(node + r, a);
      }
    }
    previous = {node, layer.nodes};
  }
  return horizontal_sum(f4) + out_bias;
}

PANELBASS_AVX2_FMA void tanh_avx2_fma(std::span<double> x) noexcept {
  std::size_t i = 0;
  for (; i + 4 <= x.size(); i += 4) _mm256_storeu_pd(x.data() + i, tanh4(_mm256_loadu_pd(x.data() + i)));
  if (i < x.size()) {
    double tail[4] = {0.0, 0.0, 0.0, 0.0};
    std::copy(x.begin() + static_cast<std::ptrdiff_t>(i), x.end(), tail);
    _mm256_storeu_pd(tail, tanh4(_mm256_loadu_pd(tail)));
    std::copy(tail, tail + (x.size() - i), x.begin() + static_cast<std::ptrdiff_t>(i));
  }
}

}  // namespace panelbass::models::detail

#else  // not x86-64: never called (avx2_fma_available() is false); defined so the library links.

namespace panelbass::models::detail {
double forward_avx2_fma(const KernelView&, std::span<const double>, std::span<const double>) noexcept { return 0.0; }
void tanh_avx2_fma(std::span<double>) noexcept {}
}  // namespace panelbass::models::detail

#endif

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
// The shortest dependent chain that keeps that accuracy (the NARX feedback waits for it every sample): n is
// rounded by adding 1.5·2^52 in the multiply-add itself (its low bits then hold n, so 2^n is two integer
// operations), and |x| > 20, where tanh rounds to ±1, is not clamped on the way in but replaced by ±1 at the
// end, off the chain (whatever the arithmetic made of it). A NaN passes through the arithmetic as a NaN.
PANELBASS_AVX2_FMA inline __m256d tanh4(__m256d x) noexcept {
  const __m256d magic = _mm256_set1_pd(6755399441055744.0);  // 1.5·2^52: adding it rounds to an integer
  const __m256d shifted = _mm256_fmadd_pd(x, _mm256_set1_pd(2.0 * 1.4426950408889634073599), magic);
  const __m256d n = _mm256_sub_pd(shifted, magic);
  __m256d r = _mm256_fnmadd_pd(n, _mm256_set1_pd(0.693145751953125), _mm256_add_pd(x, x));
  r = _mm256_fnmadd_pd(n, _mm256_set1_pd(1.42860682030941723212e-6), r);
  const __m256d r2 = _mm256_mul_pd(r, r);
  __m256d p = _mm256_fmadd_pd(_mm256_set1_pd(1.26177193074810590878e-4), r2, _mm256_set1_pd(3.02994407707441961300e-2));
  p = _mm256_fmadd_pd(p, r2, _mm256_set1_pd(9.99999999999999999910e-1));
  p = _mm256_mul_pd(p, r);
  __m256d q = _mm256_fmadd_pd(_mm256_set1_pd(3.00198505138664455042e-6), r2, _mm256_set1_pd(2.52448340349684104192e-3));
  q = _mm256_fmadd_pd(q, r2, _mm256_set1_pd(2.27265548208155028766e-1));
  q = _mm256_fmadd_pd(q, r2, _mm256_set1_pd(2.00000000000000000009e0));
  // 2^n: n + 1023 in the exponent field. The low bits of `shifted` are n + 2^51 (two's complement), and the
  // shift keeps only the 12 bits that become the exponent: exact for |n| ≤ 58 (|x| ≤ 20).
  const __m256i bits = _mm256_slli_epi64(_mm256_add_epi64(_mm256_castpd_si256(shifted), _mm256_set1_epi64x(1023)), 52);
  const __m256d scaled = _mm256_mul_pd(_mm256_castsi256_pd(bits), _mm256_add_pd(q, p));
  const __m256d below = _mm256_sub_pd(q, p);
  const __m256d t = _mm256_div_pd(_mm256_sub_pd(scaled, below), _mm256_add_pd(scaled, below));
  // |x| > 20 (false for a NaN): ±1 with x's sign.
  const __m256d sign = _mm256_set1_pd(-0.0);
  const __m256d far = _mm256_cmp_pd(_mm256_andnot_pd(sign, x), _mm256_set1_pd(20.0), _CMP_GT_OQ);
  const __m256d one = _mm256_or_pd(_mm256_and_pd(sign, x), _mm256_set1_pd(1.0));
  return _mm256_blendv_pd(t, one, far);
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

// Σ of the four lanes, in every lane: (v0 + v2) + (v1 + v3), as a horizontal sum adds them.
PANELBASS_AVX2_FMA inline __m256d all_lanes_sum(__m256d v) noexcept {
  const __m256d halves = _mm256_add_pd(v, _mm256_permute2f128_pd(v, v, 1));
  return _mm256_add_pd(halves, _mm256_permute_pd(halves, 0b0101));
}

// The first hidden layer's node inputs, rows r..r+4, from everything but head[0]: the bias and the other
// columns. head[0] (a NARX's y(k−1), the newest feedback) is added last, so in a free run everything else is
// summed before it is known and only one multiply-add lies between one output and the next one's tanh.
PANELBASS_AVX2_FMA inline __m256d first_layer_rest(const KernelView& net, std::size_t r, std::span<const double> head,
                                                   std::span<const double> tail) noexcept {
  const KernelLayer& layer = net.layers[0];
  __m256d sum = _mm256_loadu_pd(net.weights + layer.bias + r);
  __m256d odd = _mm256_setzero_pd();
  const double* w = net.weights + layer.weights + r;
  accumulate(sum, odd, w + layer.stride, layer.stride, head.subspan(1));
  accumulate(sum, odd, w + head.size() * layer.stride, layer.stride, tail);
  return _mm256_add_pd(sum, odd);
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
  // The output node's sum in two accumulators (groups of four nodes alternately), so its multiply-adds
  // overlap: free_run_avx2_fma adds in the same order.
  __m256d f_even = _mm256_setzero_pd();
  __m256d f_odd = _mm256_setzero_pd();
  for (std::size_t l = 0; l < net.layer_count; ++l) {
    const KernelLayer& layer = net.layers[l];
    double* node = net.activations + layer.out;
    const bool last = l + 1 == net.layer_count;
    // [fig 5.6] node_in = W·x + b, node_out = tanh(node_in); four nodes at a time, column by column
    for (std::size_t r = 0; r < layer.stride; r += 4) {
      __m256d sum;
      if (l == 0 && !head.empty()) {
        sum = _mm256_fmadd_pd(_mm256_loadu_pd(net.weights + layer.weights + r), _mm256_set1_pd(head[0]),
                              first_layer_rest(net, r, head, tail));
      } else {
        __m256d odd = _mm256_setzero_pd();
        sum = _mm256_loadu_pd(net.weights + layer.bias + r);
        accumulate(sum, odd, net.weights + layer.weights + r, layer.stride, l == 0 ? tail : previous);
        sum = _mm256_add_pd(sum, odd);
      }
      const __m256d a = tanh4(sum);
      // The last layer feeds the linear output node directly: F = w_out·a + b_out (padding: w = 0, a = 0).
      if (!last) {
        _mm256_storeu_pd(node + r, a);
      } else if (r % 8 == 0) {
        f_even = _mm256_fmadd_pd(_mm256_loadu_pd(out_w + r), a, f_even);
      } else {
        f_odd = _mm256_fmadd_pd(_mm256_loadu_pd(out_w + r), a, f_odd);
      }
    }
    previous = {node, layer.nodes};
  }
  return _mm256_cvtsd_f64(all_lanes_sum(_mm256_add_pd(f_even, f_odd))) + out_bias;
}

namespace {

// first_layer_rest for all G groups of four nodes at once, input by input: each input is broadcast once for
// all groups instead of once per group (the same multiply-adds in the same order per group, so the same bits).
template <int G>
PANELBASS_AVX2_FMA inline void accumulate_groups(__m256d (&sum)[G], __m256d (&odd)[G], const double*& w,
                                                 std::size_t stride, std::span<const double> x) noexcept {
  std::size_t j = 0;
  for (; j + 1 < x.size(); j += 2) {
    const __m256d even_x = _mm256_set1_pd(x[j]);
    const __m256d odd_x = _mm256_set1_pd(x[j + 1]);
    for (int g = 0; g < G; ++g) {
      sum[g] = _mm256_fmadd_pd(_mm256_loadu_pd(w + 4 * g), even_x, sum[g]);
      odd[g] = _mm256_fmadd_pd(_mm256_loadu_pd(w + stride + 4 * g), odd_x, odd[g]);
    }
    w += 2 * stride;
  }
  if (j < x.size()) {
    const __m256d even_x = _mm256_set1_pd(x[j]);
    for (int g = 0; g < G; ++g) sum[g] = _mm256_fmadd_pd(_mm256_loadu_pd(w + 4 * g), even_x, sum[g]);
    w += stride;
  }
}

// free_run_avx2_fma for one hidden layer of G groups of four nodes.
template <int G>
PANELBASS_AVX2_FMA void free_run_groups(const KernelView& net, NarxHistory& history, std::span<const double> u,
                                        std::span<double> y) noexcept {
  const KernelLayer& layer = net.layers[0];
  const std::size_t stride = layer.stride;
  const double* out_w = net.output;
  const double* newest_column = net.weights + layer.weights;
  const __m256d out_bias = _mm256_set1_pd(out_w[(net.output_inputs + 3) / 4 * 4]);
  __m256d newest = _mm256_set1_pd(history.past_outputs()[0]);
  for (std::size_t k = 0; k < u.size(); ++k) {
    history.push_input(u[k]);
    const std::span<const double> head = history.past_outputs();
    // [fig 5.6] node_in = W·x + b without y(k−1)'s column: everything known before y(k−1) is
    __m256d sum[G], odd[G];
    for (int g = 0; g < G; ++g) {
      sum[g] = _mm256_loadu_pd(net.weights + layer.bias + 4 * g);
      odd[g] = _mm256_setzero_pd();
    }
    const double* w = newest_column + stride;
    accumulate_groups<G>(sum, odd, w, stride, head.subspan(1));
    accumulate_groups<G>(sum, odd, w, stride, history.past_inputs());
    // [5G] y(k) = F(y(k−1..k−na), u(k−nk..k−nk−nb)), F = w_out·tanh(node_in + w_y1·y(k−1)) + b_out
    __m256d f_even = _mm256_setzero_pd();
    __m256d f_odd = _mm256_setzero_pd();
    for (int g = 0; g < G; ++g) {
      const __m256d a =
          tanh4(_mm256_fmadd_pd(_mm256_loadu_pd(newest_column + 4 * g), newest, _mm256_add_pd(sum[g], odd[g])));
      if (g % 2 == 0) {
        f_even = _mm256_fmadd_pd(_mm256_loadu_pd(out_w + 4 * g), a, f_even);
      } else {
        f_odd = _mm256_fmadd_pd(_mm256_loadu_pd(out_w + 4 * g), a, f_odd);
      }
    }
    newest = _mm256_add_pd(all_lanes_sum(_mm256_add_pd(f_even, f_odd)), out_bias);
    const double out = _mm256_cvtsd_f64(newest);
    history.push_output(out);
    y[k] = out;
  }
}

}  // namespace

PANELBASS_AVX2_FMA void free_run_avx2_fma(const KernelView& net, NarxHistory& history, std::span<const double> u,
                                          std::span<double> y) noexcept {
  // One hidden layer of up to 32 nodes: forward_avx2_fma's arithmetic, in its order, with the newest output
  // kept in a register (in every lane, as the multiply-add that takes it wants it) instead of stored, loaded
  // and broadcast, and each input broadcast once for all nodes.
  if (net.layer_count == 1 && !history.past_outputs().empty()) {
    switch (net.layers[0].stride / 4) {
      case 1: return free_run_groups<1>(net, history, u, y);
      case 2: return free_run_groups<2>(net, history, u, y);
      case 3: return free_run_groups<3>(net, history, u, y);
      case 4: return free_run_groups<4>(net, history, u, y);
      case 5: return free_run_groups<5>(net, history, u, y);
      case 6: return free_run_groups<6>(net, history, u, y);
      case 7: return free_run_groups<7>(net, history, u, y);
      case 8: return free_run_groups<8>(net, history, u, y);
      default: break;
    }
  }
  for (std::size_t k = 0; k < u.size(); ++k) {
    history.push_input(u[k]);
    y[k] = forward_avx2_fma(net, history.past_outputs(), history.past_inputs());
    history.push_output(y[k]);
  }
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
void free_run_avx2_fma(const KernelView&, NarxHistory&, std::span<const double>, std::span<double>) noexcept {}
}  // namespace panelbass::models::detail

#endif

#pragma once
// The one NARX regressor and output history ([5G]): the layout x(k) = [y(k−1)..y(k−na), u(k−nk)..u(k−nk−nb)]
// written once, read from whole records (NarxModel::regressor, training) or from histories kept sample by
// sample (the neural feedback controller's plant model, the tests' NarxStage).

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <span>
#include <vector>

namespace panelbass::models {

struct NarxStructure;

/// [5G] Fills x = [y(k−1)..y(k−na), u(k−nk)..u(k−nk−nb)] from `past_output(i)` = y(k−1−i) and
/// `input(j)` = u(k−j); x has na + nb + 1 entries.
template <class PastOutput, class Input>
void fill_narx_regressor(int na, int nb, int nk, PastOutput&& past_output, Input&& input,
                         Eigen::Ref<Eigen::VectorXd> x) {
  for (int i = 0; i < na; ++i) x[i] = past_output(i);
  for (int j = 0; j <= nb; ++j) x[na + j] = input(nk + j);
}

/// The recent past of one signal, newest first: a fixed length, sized once, pushed without allocating.
/// A mirrored ring: each sample is written twice, `length` apart, so the newest `length` samples always
/// lie contiguous (newest first) and a push moves one index instead of shifting the whole history.
class SignalHistory {
 public:
  /// No past.
  SignalHistory() = default;
  /// `length` past samples, all 0.
  explicit SignalHistory(std::size_t length) : length_(length), values_(2 * length, 0.0) {}
  /// `x` becomes the newest sample (index 0); the oldest is dropped.
  void push(double x) noexcept {
    if (length_ == 0) return;
    newest_ = newest_ == 0 ? length_ - 1 : newest_ - 1;
    values_[newest_] = x;
    values_[newest_ + length_] = x;
  }
  /// The sample `i` places back from the newest (0 = newest).
  double operator[](std::size_t i) const noexcept { return values_[newest_ + i]; }
  /// Number of samples kept.
  std::size_t size() const noexcept { return length_; }
  /// Every sample, newest first, contiguous (valid until the next push).
  std::span<const double> newest_first() const noexcept { return {values_.data() + newest_, length_}; }
  /// Copies every sample, newest first, into x[offset..offset + size()).
  void copy_to(Eigen::Ref<Eigen::VectorXd> x, Eigen::Index offset) const noexcept {
    for (std::size_t i = 0; i < length_; ++i) x[offset + static_cast<Eigen::Index>(i)] = (*this)[i];
  }
  /// Every sample back to 0.
  void reset() noexcept {
    std::fill(values_.begin(), values_.end(), 0.0);
    newest_ = 0;
  }

 private:
  std::size_t length_ = 0;
  std::size_t newest_ = 0;      // position of the newest sample in the first half
  std::vector<double> values_;  // values_[newest_ + i] = values_[newest_ + i ± length_] = sample i back
};

/// A NARX model's inputs and outputs kept sample by sample (scaled units) and the regressor built from
/// them: push u(k), read regressor() for y(k), push the y(k) that is to count as the past.
class NarxHistory {
 public:
  /// No model.
  NarxHistory() = default;
  /// At rest for `structure`: nk + nb + 1 past inputs, na past outputs, all 0.
  explicit NarxHistory(const NarxStructure& structure);
  /// u(k) becomes the newest input.
  void push_input(double u) noexcept { inputs_.push(u); }
  /// y(k) becomes the newest past output (y(k−1) of the next regressor).
  void push_output(double y) noexcept { outputs_.push(y); }
  /// [5G] x(k) = [y(k−1)..y(k−na), u(k−nk)..u(k−nk−nb)] from the histories; allocation-free.
  const Eigen::VectorXd& regressor() noexcept;
  /// The regressor's first part without copying: y(k−1)..y(k−na), contiguous.
  std::span<const double> past_outputs() const noexcept { return outputs_.newest_first(); }
  /// The regressor's second part without copying: u(k−nk)..u(k−nk−nb), contiguous.
  std::span<const double> past_inputs() const noexcept {
    return inputs_.newest_first().subspan(static_cast<std::size_t>(nk_));
  }
  /// Every past sample back to 0.
  void reset() noexcept;

 private:
  int na_ = 0, nb_ = -1, nk_ = 0;
  SignalHistory inputs_;   // u(k − j), j = 0..nk + nb
  SignalHistory outputs_;  // y(k − 1 − i), i = 0..na − 1
  Eigen::VectorXd x_;
};

}  // namespace panelbass::models

// The one NARX regressor and history: SignalHistory keeps the newest sample first, NarxHistory built
// sample by sample gives the regressor written out by hand ([5G], zero before the start) and
// NarxModel::regressor on the whole record, for structures with and without delay and past outputs.
#include "models/narx/narx_history.h"

#include <gtest/gtest.h>

#include <cmath>
#include <span>
#include <vector>

#include "models/narx/narx_model.h"

namespace panelbass::models {
namespace {

TEST(SignalHistory, KeepsTheNewestSampleFirstAndDropsTheOldest) {
  SignalHistory h(3);
  h.push(1.0);
  h.push(2.0);
  EXPECT_EQ(h[0], 2.0);
  EXPECT_EQ(h[1], 1.0);
  EXPECT_EQ(h[2], 0.0);
  h.push(3.0);
  h.push(4.0);
  Eigen::VectorXd x = Eigen::VectorXd::Constant(5, -1.0);
  h.copy_to(x, 1);
  EXPECT_EQ(x, (Eigen::VectorXd(5) << -1.0, 4.0, 3.0, 2.0, -1.0).finished());
  h.reset();
  EXPECT_EQ(h[0], 0.0);
  SignalHistory none;
  none.push(1.0);  // nothing kept, nothing broken
  EXPECT_EQ(none.size(), 0u);
}

TEST(SignalHistory, ItsContiguousWindowIsTheShiftedHistoryAcrossManyWrapArounds) {
  // Against a history shifted by hand, newest first, over more pushes than the ring has places many times.
  for (std::size_t length : {1u, 4u, 17u}) {
    SignalHistory h(length);
    std::vector<double> shifted(length, 0.0);
    for (int k = 0; k < 100; ++k) {
      const double x = std::sin(0.7 * k) + 0.01 * k;
      h.push(x);
      shifted.insert(shifted.begin(), x);
      shifted.pop_back();
      const std::span<const double> window = h.newest_first();
      ASSERT_EQ(std::vector<double>(window.begin(), window.end()), shifted) << length << " " << k;
      for (std::size_t i = 0; i < length; ++i) ASSERT_EQ(h[i], shifted[i]);
    }
    h.reset();
    h.push(5.0);
    EXPECT_EQ(h[0], 5.0);
    for (std::size_t i = 1; i < length; ++i) EXPECT_EQ(h[i], 0.0);
  }
}

TEST(NarxHistory, SampleBySampleItIsTheRegressorOfTheWholeRecord) {
  for (const auto& [na, nb, nk] : {std::tuple{2, 1, 1}, std::tuple{0, 2, 0}, std::tuple{3, 0, 4}, std::tuple{1, 3, 2}}) {
    NarxStructure s;
    s.na = na;
    s.nb = nb;
    s.nk = nk;
    s.hidden = {2};
    const NarxModel m = NarxModel::with_structure(s, Scaling{}, 3000.0);
    Eigen::VectorXd u(30), y(30);
    for (Eigen::Index k = 0; k < u.size(); ++k) {
      u[k] = std::sin(0.4 * k) + 1.0;
      y[k] = std::cos(0.9 * k) - 2.0;
    }
    NarxHistory history(s);
    Eigen::VectorXd from_record(s.inputs());
    for (Eigen::Index k = 0; k < u.size(); ++k) {
      history.push_input(u[k]);
      const Eigen::VectorXd x = history.regressor();
      // [5G] by hand: [y(k−1)..y(k−na), u(k−nk)..u(k−nk−nb)], zero before the record
      std::vector<double> expected;
      for (int i = 1; i <= na; ++i) expected.push_back(k - i >= 0 ? y[k - i] : 0.0);
      for (int j = 0; j <= nb; ++j) expected.push_back(k - nk - j >= 0 ? u[k - nk - j] : 0.0);
      ASSERT_EQ(x.size(), static_cast<Eigen::Index>(expected.size()));
      for (Eigen::Index i = 0; i < x.size(); ++i) ASSERT_EQ(x[i], expected[static_cast<std::size_t>(i)]) << k << " " << i;
      m.regressor(u, y, k, from_record);
      ASSERT_EQ(from_record, x) << k;
      // The same regressor in two contiguous parts, as the engine's NARX stage reads it without a copy.
      std::vector<double> parts(history.past_outputs().begin(), history.past_outputs().end());
      parts.insert(parts.end(), history.past_inputs().begin(), history.past_inputs().end());
      ASSERT_EQ(parts, expected) << k;
      history.push_output(y[k]);
    }
    history.reset();
    history.push_input(0.0);
    EXPECT_EQ(history.regressor(), Eigen::VectorXd::Zero(s.inputs()));
  }
}

}  // namespace
}  // namespace panelbass::models

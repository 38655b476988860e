// Averaging restarts: the one ss model that holds several side by side against the mean of the members'
// own free runs and predictions, its refusals, and the greedy selection against J computed by hand.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "models/state_space_nn/ss_average.h"
#include "models/state_space_nn/ss_model.h"
#include "models/validation/performance.h"
#include "tests/support/expect_error.h"
#include "tests/support/noise.h"

namespace panelbass::models {
namespace {

using testing_support::message_of;
using testing_support::uniform_noise;

// A member with every part of θ non-zero (random, seeded) and a stable A; `hidden_input` false holds W1's
// input column at zero, as identify ss does for --hidden-states-only.
SsModel average_member(int states, int hidden, int encoder_hidden, bool hidden_input, std::uint64_t seed) {
  SsModel m;
  m.structure.states = states;
  m.structure.hidden = hidden;
  m.structure.lags = 4;
  m.structure.encoder_hidden = encoder_hidden;
  m.structure.hidden_input = hidden_input;
  m.fs = 1000.0;
  m.scaling = {0.1, 2.0, -0.2, 0.5};
  m.theta = 0.3 * uniform_noise(m.structure.parameter_count(), 1.0, seed);
  auto p = ss_parts(m.structure, m.theta.data());
  p.A = Eigen::MatrixXd::Identity(states, states) * 0.8 + 0.1 * uniform_noise(states * states, 1.0, seed + 1).reshaped(states, states);
  if (!hidden_input) p.W1.col(states).setZero();
  m.meta = {{"seed", seed}};
  return m;
}

TEST(SsAverage, FreeRunAndPredictionAreTheMeanOfTheMembers) {
  const std::vector<SsModel> members{average_member(3, 5, 2, true, 11), average_member(2, 4, 0, false, 21), average_member(4, 3, 3, true, 31)};
  const SsModel average = ss_average(members);
  EXPECT_EQ(average.structure.states, 9);
  EXPECT_EQ(average.structure.hidden, 12);
  EXPECT_EQ(average.structure.encoder_hidden, 5);
  ASSERT_EQ(average.meta["members"].size(), 3u);
  EXPECT_EQ(average.meta["members"][1]["seed"], 21);

  const Eigen::VectorXd u = uniform_noise(300, 1.0, 5), y = 0.4 * uniform_noise(300, 1.0, 6);
  Eigen::VectorXd mean_run = Eigen::VectorXd::Zero(u.size()), mean_prediction = Eigen::VectorXd::Zero(u.size());
  for (const SsModel& m : members) {
    mean_run += m.simulate(u, y, 20) / 3.0;
    mean_prediction += m.predict(u, y) / 3.0;
  }
  const Eigen::VectorXd run = average.simulate(u, y, 20), prediction = average.predict(u, y);
  EXPECT_LT((run - mean_run).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + mean_run.cwiseAbs().maxCoeff()));
  EXPECT_LT((prediction - mean_prediction).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + mean_prediction.cwiseAbs().maxCoeff()));
  // the file keeps it: the loader's shape and free-run checks pass and the run is the same
  const SsModel read = ss_model_from_json(ss_model_to_json(average));
  EXPECT_EQ(read.simulate(u, y, 20), run);
}

TEST(SsAverage, MembersThatCannotShareOneModelAreRefusedByNumber) {
  const SsModel a = average_member(2, 3, 0, true, 1);
  auto refusal = [&](const SsModel& b) { return message_of<std::invalid_argument>([&] { ss_average({a, b}); }, "accepted"); };
  SsModel other_data = average_member(2, 3, 0, true, 2);
  other_data.scaling.y_scale = 0.25;
  EXPECT_NE(refusal(other_data).find("member 2 has another scaling"), std::string::npos) << refusal(other_data);
  SsModel other_lags = average_member(2, 3, 0, true, 2);
  other_lags.structure.lags = 5;
  other_lags.theta = Eigen::VectorXd::Zero(other_lags.structure.parameter_count());
  EXPECT_NE(refusal(other_lags).find("member 2 reads 5 lags, the first 4"), std::string::npos) << refusal(other_lags);
  SsModel polynomial = average_member(2, 3, 0, true, 2);
  polynomial.structure.poly_degree = 3;
  polynomial.theta = Eigen::VectorXd::Zero(polynomial.structure.parameter_count());
  EXPECT_NE(refusal(polynomial).find("member 2 has a polynomial"), std::string::npos) << refusal(polynomial);
  SsModel cubic = average_member(2, 3, 0, true, 2);
  cubic.structure.activation = SsActivation::cubic;
  EXPECT_NE(refusal(cubic).find("member 2 has cubic nodes, the first tanh"), std::string::npos) << refusal(cubic);
  EXPECT_THROW(ss_average({}), std::invalid_argument);
  const std::vector<SsModel> eleven(11, average_member(6, 2, 0, true, 3));
  const std::string too_many = message_of<std::invalid_argument>([&] { ss_average(eleven); }, "accepted");
  EXPECT_NE(too_many.find("66 states in all, more than the 64"), std::string::npos) << too_many;
}

TEST(SsAverage, SelectionKeepsTheForwardOrdersPrefixOfLowestJ) {
  // y measured; candidates y + e with independent errors: two of one size, one twice as large, one ten times.
  const Eigen::Index n = 4000, init = 50;
  const Eigen::VectorXd y = uniform_noise(n, 1.0, 1);
  const Eigen::VectorXd e1 = 0.010 * uniform_noise(n, 1.0, 2), e2 = 0.011 * uniform_noise(n, 1.0, 3);
  const Eigen::VectorXd e3 = 0.020 * uniform_noise(n, 1.0, 4), e4 = 0.1 * uniform_noise(n, 1.0, 5);
  const std::vector<Eigen::VectorXd> runs{y + e3, y + e2, y + e4, y + e1};
  const AverageSelection s = select_average(runs, y, init);
  auto j = [&](const Eigen::VectorXd& error) {
    return 100.0 * error.tail(n - init).squaredNorm() / y.tail(n - init).squaredNorm();
  };
  ASSERT_EQ(s.candidate_j_percent.size(), 4u);
  EXPECT_NEAR(s.candidate_j_percent[2], j(e4), 1e-12);
  // e1 alone is best; with e2 the error power halves; e3 then raises it (0.020² is more than it averages away),
  // e4 raises it further: the order e1, e2, e3, e4, the members the first two.
  ASSERT_GT(j((e1 + e2 + e3) / 3.0), j((e1 + e2) / 2.0));
  EXPECT_EQ(s.order, (std::vector<int>{3, 1, 0, 2}));
  ASSERT_EQ(s.j_percent.size(), 4u);
  EXPECT_NEAR(s.j_percent[0], j(e1), 1e-12);
  EXPECT_NEAR(s.j_percent[1], j((e1 + e2) / 2.0), 1e-12);
  EXPECT_NEAR(s.j_percent[2], j((e1 + e2 + e3) / 3.0), 1e-12);
  EXPECT_NEAR(s.j_percent[3], j((e1 + e2 + e3 + e4) / 4.0), 1e-12);
  EXPECT_EQ(s.chosen, (std::vector<int>{3, 1}));

  // A member that raises J one step is kept when a later one lowers it below: two errors that cancel
  // (+d and −d) beside a small independent one.
  const Eigen::VectorXd d = 0.03 * uniform_noise(n, 1.0, 6), small = 0.01 * uniform_noise(n, 1.0, 7);
  const AverageSelection cancel = select_average({y + d, y + small, y - d + 0.1 * small}, y, init);
  ASSERT_GT(cancel.j_percent[1], cancel.j_percent[0]) << "the second addition raises J";
  EXPECT_LT(cancel.j_percent[2], cancel.j_percent[0]);
  EXPECT_EQ(cancel.chosen.size(), 3u);

  Eigen::VectorXd broken = y;
  broken(7) = NAN;
  EXPECT_THROW(select_average({y, broken}, y, init), std::invalid_argument);
  EXPECT_THROW(select_average({y.head(10)}, y, init), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::models

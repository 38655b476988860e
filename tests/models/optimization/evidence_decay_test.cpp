// MacKay's evidence update of the weight decay against its closed form for a linear least-squares fit: the
// effective number of parameters γ = Σ λᵢ/(λᵢ + D) from the eigenvalues λᵢ of ΦᵀΦ (Bishop 1995, §10.4),
// computed here by an eigendecomposition, not by the trace of an inverse as the code does.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "models/optimization/evidence_decay.h"

namespace panelbass::models {
namespace {

Eigen::MatrixXd evidence_test_matrix(Eigen::Index rows, Eigen::Index cols, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> d;
  Eigen::MatrixXd m(rows, cols);
  for (auto& v : m.reshaped()) v = d(rng);
  return m;
}

// γ·E/((N − γ)·‖θ‖²) with γ from the eigenvalues of ΦᵀΦ.
double closed_form(const Eigen::MatrixXd& phi, double E, double D, const Eigen::VectorXd& theta) {
  const Eigen::VectorXd lambda = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(phi.transpose() * phi).eigenvalues();
  const double gamma = (lambda.array() / (lambda.array() + D)).sum();
  return gamma * E / ((static_cast<double>(phi.rows()) - gamma) * theta.squaredNorm());
}

TEST(EvidenceWeightDecay, EqualsTheClosedFormOfALinearFit) {
  // columns of very different size, so that γ is well below P: some directions are the prior's
  Eigen::MatrixXd phi = evidence_test_matrix(200, 6, 1);
  for (int c = 0; c < 6; ++c) phi.col(c) *= std::pow(0.1, c);
  const Eigen::VectorXd theta = evidence_test_matrix(6, 1, 2);
  const double E = 3.7, D = 0.5;
  const Eigen::MatrixXd regularised = phi.transpose() * phi + D * Eigen::MatrixXd::Identity(6, 6);
  const double expected = closed_form(phi, E, D, theta);
  EXPECT_NEAR(evidence_weight_decay(regularised, E, 200.0, D, theta), expected, 1e-12 * expected);
  // D = 0: every direction is the data's, γ = P
  const double unregularised = evidence_weight_decay(phi.transpose() * phi, E, 200.0, 0.0, theta);
  EXPECT_NEAR(unregularised, 6.0 * E / (194.0 * theta.squaredNorm()), 1e-12 * unregularised);
}

TEST(EvidenceWeightDecay, HeldParametersAreLeftOut) {
  // a mask holding parameters 1 and 4: the update of the free four alone
  const Eigen::MatrixXd phi = evidence_test_matrix(100, 6, 3);
  const Eigen::VectorXd theta = evidence_test_matrix(6, 1, 4);
  const double E = 1.3, D = 2.0;
  Eigen::VectorXd mask = Eigen::VectorXd::Ones(6);
  mask(1) = mask(4) = 0.0;
  Eigen::MatrixXd phi_free(100, 4);
  Eigen::VectorXd theta_free(4);
  for (int c = 0, f = 0; c < 6; ++c) {
    if (mask(c) == 0.0) continue;
    phi_free.col(f) = phi.col(c);
    theta_free(f++) = theta(c);
  }
  const Eigen::MatrixXd regularised = phi.transpose() * phi + D * Eigen::MatrixXd::Identity(6, 6);
  const double expected = closed_form(phi_free, E, D, theta_free);
  EXPECT_NEAR(evidence_weight_decay(regularised, E, 100.0, D, theta, mask), expected, 1e-12 * expected);
}

TEST(EvidenceWeightDecay, AnUndefinedUpdateKeepsTheDecay) {
  const Eigen::MatrixXd identity = Eigen::MatrixXd::Identity(3, 3);
  EXPECT_EQ(evidence_weight_decay(identity, 1.0, 50.0, 0.3, Eigen::VectorXd::Zero(3)), 0.3);      // θ = 0
  EXPECT_EQ(evidence_weight_decay(-identity, 1.0, 50.0, 0.3, Eigen::VectorXd::Ones(3)), 0.3);     // not definite
  EXPECT_EQ(evidence_weight_decay(identity, 1.0, 2.0, 0.0, Eigen::VectorXd::Ones(3)), 0.0);       // γ = 3 ≥ N = 2
}

}  // namespace
}  // namespace panelbass::models

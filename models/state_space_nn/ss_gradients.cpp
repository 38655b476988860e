#include "models/state_space_nn/ss_gradients.h"

#include <stdexcept>
#include <string>
#include <utility>

namespace panelbass::models {
namespace {

void require_windows(const Eigen::VectorXd& u, const Eigen::VectorXd& y, const SsWindows& windows) {
  if (u.size() != y.size()) throw std::invalid_argument("ss_window_loss: input and output lengths differ");
  if (windows.length < 1 || windows.starts.empty()) throw std::invalid_argument("ss_window_loss: no windows");
  for (const Eigen::Index k0 : windows.starts) {
    if (k0 < 0 || k0 + windows.length > u.size()) {
      throw std::invalid_argument("ss_window_loss: window [" + std::to_string(k0) + ", " +
                                  std::to_string(k0 + windows.length) + ") leaves the data of " +
                                  std::to_string(u.size()) + " samples");
    }
  }
}

/// The encoder's regressors z(k0) of the windows (2L × B).
Eigen::MatrixXd regressors(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, const SsWindows& windows) {
  const Eigen::Index B = static_cast<Eigen::Index>(windows.starts.size());
  Eigen::MatrixXd Z(2 * m.structure.lags, B);
  for (Eigen::Index b = 0; b < B; ++b) ss_regressor(u, y, windows.starts[static_cast<std::size_t>(b)], m.structure.lags, Z.col(b));
  return Z;
}

}  // namespace

double ss_window_loss(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, const SsWindows& windows,
                      Eigen::VectorXd* gradient) {
  require_windows(u, y, windows);
  const Eigen::MatrixXd x0 = ss_encoded_states(m, u, y, windows);
  Eigen::MatrixXd state_gradient;
  const double loss = ss_window_loss_from_states(m, u, y, windows, x0, {}, gradient, &state_gradient);
  if (gradient != nullptr) ss_add_encoder_gradient(m, u, y, windows, state_gradient, *gradient);
  return loss;
}

Eigen::MatrixXd ss_encoded_states(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                  const SsWindows& windows) {
  require_windows(u, y, windows);
  const auto p = ss_parts(m.structure, m.theta.data());
  Eigen::MatrixXd x0(m.structure.states, static_cast<Eigen::Index>(windows.starts.size())), G;
  ss_encode(p, regressors(m, u, y, windows), G, x0);
  return x0;
}

void ss_add_encoder_gradient(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                             const SsWindows& windows, const Eigen::MatrixXd& state_gradient, Eigen::VectorXd& gradient) {
  const SsStructure& s = m.structure;
  const auto p = ss_parts(s, m.theta.data());
  auto g = ss_parts(s, gradient.data());
  const Eigen::MatrixXd Z = regressors(m, u, y, windows);
  Eigen::MatrixXd x0(s.states, Z.cols()), G;
  ss_encode(p, Z, G, x0);
  // x(k0) = E·z + V2·tanh(V1·z + c1) + c2
  const Eigen::MatrixXd& lambda = state_gradient;
  g.E.noalias() += lambda * Z.transpose();
  g.c2 += lambda.rowwise().sum();
  if (s.encoder_hidden > 0) {
    g.V2.noalias() += lambda * G.transpose();
    Eigen::MatrixXd dg = p.V2.transpose() * lambda;
    dg.array() *= 1.0 - G.array().square();
    g.V1.noalias() += dg * Z.transpose();
    g.c1 += dg.rowwise().sum();
  }
}

double ss_window_loss_from_states(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                                  const SsWindows& windows, const Eigen::MatrixXd& x0, const SsFinalStateTerm& final_term,
                                  Eigen::VectorXd* gradient, Eigen::MatrixXd* state_gradient) {
  require_windows(u, y, windows);
  const SsStructure& s = m.structure;
  const Eigen::Index n = s.states, T = windows.length, B = static_cast<Eigen::Index>(windows.starts.size());
  if (x0.rows() != n || x0.cols() != B) {
    throw std::invalid_argument("ss_window_loss: " + std::to_string(B) + " initial states of " + std::to_string(n) +
                                " entries needed, got " + std::to_string(x0.rows()) + " × " + std::to_string(x0.cols()));
  }
  const auto p = ss_parts(s, m.theta.data());

  // Forward: T steps of every window side by side (one column each) from its x(k0).
  Eigen::MatrixXd U(T, B), Y(T, B);
  for (Eigen::Index b = 0; b < B; ++b) {
    const Eigen::Index k0 = windows.starts[static_cast<std::size_t>(b)];
    U.col(b) = u.segment(k0, T);
    Y.col(b) = y.segment(k0, T);
  }
  Eigen::MatrixXd X(n, B * (T + 1)), H(s.hidden, B * T), Hpre(s.hidden, B * T);
  X.leftCols(B) = x0;
  SsStepWork work;
  Eigen::MatrixXd E(T, B);  // simulation errors ŷ − y
  Eigen::RowVectorXd yk(B);
  for (Eigen::Index t = 0; t < T; ++t) {
    ss_step(p, X.middleCols(t * B, B), U.row(t), work, yk, X.middleCols((t + 1) * B, B));
    H.middleCols(t * B, B) = work.hidden;
    Hpre.middleCols(t * B, B) = work.pre;
    E.row(t) = yk - Y.row(t);
  }
  const double scale = 1.0 / static_cast<double>(B * T);
  // Backward through time: Λ(t) = dV/dx(t), from Λ(T) = the final-state term's gradient (or 0).
  Eigen::MatrixXd lambda = Eigen::MatrixXd::Zero(n, B);
  double loss = E.squaredNorm() * scale;
  if (final_term) loss += final_term(X.rightCols(B), lambda);
  if (gradient == nullptr) return loss;

  gradient->setZero(s.parameter_count());
  auto g = ss_parts(s, gradient->data());
  Eigen::MatrixXd dnet(n + 1, B), dhidden(s.hidden, B), monomials, dmonomials;
  Eigen::RowVectorXd e(B);
  for (Eigen::Index t = T - 1; t >= 0; --t) {
    const auto Xt = X.middleCols(t * B, B);
    const auto Ht = H.middleCols(t * B, B);
    const auto Ut = U.row(t);
    e = 2.0 * scale * E.row(t);
    // ∂V/∂[f; h] = [Λ(t+1); e(t)]
    dnet.topRows(n) = lambda;
    dnet.row(n) = e;
    g.A.noalias() += lambda * Xt.transpose();
    g.B.noalias() += lambda * Ut.transpose();
    g.C.noalias() += e * Xt.transpose();
    g.D(0, 0) += e.dot(Ut);
    g.W2.noalias() += dnet * Ht.transpose();
    g.b2 += dnet.rowwise().sum();
    // through σ: (W2ᵀ·∂[f; h]) ⊙ σ′ (1 − H² for tanh, 3·pre² for the cube)
    dhidden.noalias() = p.W2.transpose() * dnet;
    dhidden.array() *= ss_activation_slope(s.activation, Hpre.middleCols(t * B, B), Ht);
    g.W1.leftCols(n).noalias() += dhidden * Xt.transpose();
    if (s.hidden_input) g.W1.col(n).noalias() += dhidden * Ut.transpose();  // else unread: no gradient
    g.b1 += dhidden.rowwise().sum();
    // Λ(t) = Aᵀ·Λ(t+1) + Cᵀ·e(t) + W1ₓᵀ·δ(t)
    Eigen::MatrixXd next = p.A.transpose() * lambda;
    next.noalias() += p.C.transpose() * e;
    next.noalias() += p.W1.leftCols(n).transpose() * dhidden;
    if (p.P.cols() > 0) {
      // the polynomial: ∂V/∂P = ∂[f; h]·ζᵀ, and Λ(t) gains (∂ζ/∂x)ᵀ·Pᵀ·∂[f; h]
      ss_monomials(work.factors, Xt, Ut, monomials);
      g.P.noalias() += dnet * monomials.transpose();
      dmonomials.noalias() = p.P.transpose() * dnet;
      ss_monomials_backward(work.factors, Xt, Ut, dmonomials, next);
    }
    lambda.swap(next);
  }
  if (state_gradient != nullptr) *state_gradient = std::move(lambda);
  return loss;
}

}  // namespace panelbass::models

#include "models/state_space_nn/ss_gradients.h"

#include <stdexcept>
#include <string>

namespace panelbass::models {

double ss_window_loss(const SsModel& m, const Eigen::VectorXd& u, const Eigen::VectorXd& y, const SsWindows& windows,
                      Eigen::VectorXd* gradient) {
  if (u.size() != y.size()) throw std::invalid_argument("ss_window_loss: input and output lengths differ");
  const SsStructure& s = m.structure;
  const Eigen::Index n = s.states, T = windows.length, B = static_cast<Eigen::Index>(windows.starts.size());
  if (T < 1 || B < 1) throw std::invalid_argument("ss_window_loss: no windows");
  for (const Eigen::Index k0 : windows.starts) {
    if (k0 < 0 || k0 + T > u.size()) {
      throw std::invalid_argument("ss_window_loss: window [" + std::to_string(k0) + ", " + std::to_string(k0 + T) +
                                  ") leaves the data of " + std::to_string(u.size()) + " samples");
    }
  }
  const auto p = ss_parts(s, m.theta.data());

  // Forward: the encoder's x(k0), then T steps of every window side by side (one column each).
  Eigen::MatrixXd Z(2 * s.lags, B), U(T, B), Y(T, B);
  for (Eigen::Index b = 0; b < B; ++b) {
    const Eigen::Index k0 = windows.starts[static_cast<std::size_t>(b)];
    ss_regressor(u, y, k0, s.lags, Z.col(b));
    U.col(b) = u.segment(k0, T);
    Y.col(b) = y.segment(k0, T);
  }
  Eigen::MatrixXd X(n, B * (T + 1)), H(s.hidden, B * T), Hpre(s.hidden, B * T), G;
  ss_encode(p, Z, G, X.leftCols(B));
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
  const double loss = E.squaredNorm() * scale;
  if (gradient == nullptr) return loss;

  // Backward through time: Λ(t) = dV/dx(t), from Λ(T) = 0.
  gradient->setZero(s.parameter_count());
  auto g = ss_parts(s, gradient->data());
  Eigen::MatrixXd lambda = Eigen::MatrixXd::Zero(n, B), dnet(n + 1, B), dhidden(s.hidden, B), monomials, dmonomials;
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
  // Into the encoder: x(k0) = E·z + V2·tanh(V1·z + c1) + c2.
  g.E.noalias() += lambda * Z.transpose();
  g.c2 += lambda.rowwise().sum();
  if (s.encoder_hidden > 0) {
    g.V2.noalias() += lambda * G.transpose();
    Eigen::MatrixXd dg = p.V2.transpose() * lambda;
    dg.array() *= 1.0 - G.array().square();
    g.V1.noalias() += dg * Z.transpose();
    g.c1 += dg.rowwise().sum();
  }
  return loss;
}

}  // namespace panelbass::models

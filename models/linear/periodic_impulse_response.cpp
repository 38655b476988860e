#include "models/linear/periodic_impulse_response.h"

#include <Eigen/Cholesky>
#include <complex>
#include <stdexcept>
#include <string>
#include <unsupported/Eigen/FFT>

namespace panelbass::models {
namespace {

/// The DFT of each column of x (N×c): N×c complex.
Eigen::MatrixXcd dft_columns(const Eigen::MatrixXd& x, Eigen::FFT<double>& fft) {
  Eigen::MatrixXcd X(x.rows(), x.cols());
  Eigen::VectorXcd column(x.rows());
  for (Eigen::Index c = 0; c < x.cols(); ++c) {
    const Eigen::VectorXd in = x.col(c);
    fft.fwd(column, in);
    X.col(c) = column;
  }
  return X;
}

}  // namespace

std::vector<Eigen::MatrixXd> estimate_periodic_impulse_response(const std::vector<Eigen::MatrixXd>& u,
                                                                const std::vector<Eigen::MatrixXd>& y,
                                                                Eigen::Index taps, double ridge) {
  const char* where = "periodic impulse response: ";
  if (u.empty() || u.size() != y.size()) {
    throw std::invalid_argument(std::string(where) + std::to_string(u.size()) + " input and " +
                                std::to_string(y.size()) + " output realisations");
  }
  const Eigen::Index N = u.front().rows(), m = u.front().cols(), p = y.front().cols();
  for (std::size_t r = 0; r < u.size(); ++r) {
    if (u[r].rows() != N || y[r].rows() != N || u[r].cols() != m || y[r].cols() != p) {
      throw std::invalid_argument(std::string(where) + "realisation " + std::to_string(r + 1) +
                                  " differs in length or channels from the first");
    }
    if (!u[r].allFinite() || !y[r].allFinite()) {
      throw std::invalid_argument(std::string(where) + "realisation " + std::to_string(r + 1) + " is not finite");
    }
  }
  if (taps < 1 || taps > N) {
    throw std::invalid_argument(std::string(where) + "taps must be in [1, " + std::to_string(N) + "], got " +
                                std::to_string(taps));
  }

  // With c_ij(τ) = Σ_t u_i(t)·u_j((t+τ) mod N) and d_io(τ) = Σ_t u_i(t)·y_o((t+τ) mod N), the normal equations of
  // y_o(t) = Σ_{j,b} g_b(o, j)·u_j(t−b) have (i,a),(j,b) entry Σ_t u_i(t−a)·u_j(t−b) = c_ij(a−b) and right side
  // Σ_t u_i(t−a)·y_o(t) = d_io(a); both are inverse DFTs of conj(U_i)·U_j and conj(U_i)·Y_o.
  Eigen::FFT<double> fft;
  std::vector<Eigen::VectorXd> c(static_cast<std::size_t>(m * m)), d(static_cast<std::size_t>(m * p));
  Eigen::MatrixXcd Suu = Eigen::MatrixXcd::Zero(N, m * m), Suy = Eigen::MatrixXcd::Zero(N, m * p);
  for (std::size_t r = 0; r < u.size(); ++r) {
    const Eigen::MatrixXcd U = dft_columns(u[r], fft), Y = dft_columns(y[r], fft);
    for (Eigen::Index i = 0; i < m; ++i) {
      for (Eigen::Index j = 0; j < m; ++j) Suu.col(i * m + j) += U.col(i).conjugate().cwiseProduct(U.col(j));
      for (Eigen::Index o = 0; o < p; ++o) Suy.col(i * p + o) += U.col(i).conjugate().cwiseProduct(Y.col(o));
    }
  }
  Eigen::VectorXd time(N);
  Eigen::VectorXcd freq(N);
  for (Eigen::Index k = 0; k < m * m; ++k) {
    freq = Suu.col(k);
    fft.inv(time, freq);
    c[static_cast<std::size_t>(k)] = time;
  }
  for (Eigen::Index k = 0; k < m * p; ++k) {
    freq = Suy.col(k);
    fft.inv(time, freq);
    d[static_cast<std::size_t>(k)] = time;
  }

  const Eigen::Index P = m * taps;  // unknowns per output, ordered (input i, lag a) → i·taps + a
  Eigen::MatrixXd normal(P, P);
  Eigen::MatrixXd right(P, p);
  for (Eigen::Index i = 0; i < m; ++i) {
    for (Eigen::Index j = 0; j < m; ++j) {
      const Eigen::VectorXd& cij = c[static_cast<std::size_t>(i * m + j)];
      for (Eigen::Index a = 0; a < taps; ++a) {
        for (Eigen::Index b = 0; b < taps; ++b) normal(i * taps + a, j * taps + b) = cij(((a - b) % N + N) % N);
      }
    }
    for (Eigen::Index o = 0; o < p; ++o) right.col(o).segment(i * taps, taps) = d[static_cast<std::size_t>(i * p + o)].head(taps);
  }
  if (ridge > 0.0) normal.diagonal().array() += ridge * normal.diagonal().mean();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(normal);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 1e-12 * ldlt.vectorD().maxCoeff())) {
    throw std::invalid_argument(std::string(where) + "the input does not excite " + std::to_string(P) +
                                " taps (give a ridge, or fewer taps)");
  }
  const Eigen::MatrixXd theta = ldlt.solve(right);

  std::vector<Eigen::MatrixXd> g(static_cast<std::size_t>(taps), Eigen::MatrixXd(p, m));
  for (Eigen::Index a = 0; a < taps; ++a) {
    for (Eigen::Index i = 0; i < m; ++i) g[static_cast<std::size_t>(a)].col(i) = theta.row(i * taps + a).transpose();
  }
  return g;
}

}  // namespace panelbass::models

#include "models/linear/mimo_state_space.h"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <numbers>
#include <stdexcept>
#include <string>

namespace panelbass::models {

void check_shape(const MimoStateSpace& ss, const char* where) {
  const Eigen::Index n = ss.A.rows(), m = ss.D.cols(), p = ss.D.rows();
  const auto fail = [&](const std::string& what) { throw std::invalid_argument(std::string(where) + ": " + what); };
  if (ss.A.cols() != n) fail("A is " + std::to_string(n) + "×" + std::to_string(ss.A.cols()) + ", not square");
  if (m < 1 || p < 1) fail("D is " + std::to_string(p) + "×" + std::to_string(m) + ": no inputs or no outputs");
  if (ss.B.rows() != n || ss.B.cols() != m) {
    fail("B is " + std::to_string(ss.B.rows()) + "×" + std::to_string(ss.B.cols()) + ", expected " + std::to_string(n) +
         "×" + std::to_string(m));
  }
  if (ss.C.rows() != p || ss.C.cols() != n) {
    fail("C is " + std::to_string(ss.C.rows()) + "×" + std::to_string(ss.C.cols()) + ", expected " + std::to_string(p) +
         "×" + std::to_string(n));
  }
  if (!ss.A.allFinite() || !ss.B.allFinite() || !ss.C.allFinite() || !ss.D.allFinite()) fail("not finite");
}

double spectral_radius(const MimoStateSpace& ss) {
  if (ss.order() == 0) return 0.0;
  return Eigen::EigenSolver<Eigen::MatrixXd>(ss.A, false).eigenvalues().cwiseAbs().maxCoeff();
}

std::vector<Eigen::MatrixXd> markov_parameters(const MimoStateSpace& ss, Eigen::Index count) {
  check_shape(ss, "markov_parameters");
  std::vector<Eigen::MatrixXd> h;
  if (count < 1) return h;
  h.push_back(ss.D);
  Eigen::MatrixXd AkB = ss.B;  // A^(k−1)·B
  for (Eigen::Index k = 1; k < count; ++k) {
    h.push_back(ss.C * AkB);
    AkB = ss.A * AkB;
  }
  return h;
}

Eigen::MatrixXd simulate(const MimoStateSpace& ss, const Eigen::MatrixXd& u, const Eigen::VectorXd& x0) {
  check_shape(ss, "simulate");
  if (u.cols() != ss.inputs()) {
    throw std::invalid_argument("simulate: the input has " + std::to_string(u.cols()) + " columns, the model " +
                                std::to_string(ss.inputs()) + " inputs");
  }
  if (x0.size() != 0 && x0.size() != ss.order()) {
    throw std::invalid_argument("simulate: initial state has " + std::to_string(x0.size()) + " entries, model has " +
                                std::to_string(ss.order()) + " states");
  }
  Eigen::VectorXd x = x0.size() ? x0 : Eigen::VectorXd::Zero(ss.order());
  Eigen::VectorXd next(ss.order());
  Eigen::MatrixXd y(u.rows(), ss.outputs());
  // The row-major copy of u keeps one sample's inputs contiguous.
  for (Eigen::Index k = 0; k < u.rows(); ++k) {
    const auto uk = u.row(k).transpose();
    y.row(k).noalias() = (ss.C * x + ss.D * uk).transpose();
    next.noalias() = ss.A * x;
    next.noalias() += ss.B * uk;
    x.swap(next);
  }
  return y;
}

Eigen::MatrixXd simulate_after_warmup(const MimoStateSpace& ss, const Eigen::MatrixXd& u, Eigen::Index warmup) {
  if (warmup < 0) throw std::invalid_argument("simulate_after_warmup: negative warm-up");
  const Eigen::Index N = u.rows();
  if (N == 0) throw std::invalid_argument("simulate_after_warmup: empty input");
  Eigen::MatrixXd extended(warmup + N, u.cols());
  for (Eigen::Index k = 0; k < warmup; ++k) {
    // sample −warmup + k of the periodic continuation, i.e. (k − warmup) mod N
    const Eigen::Index source = ((k - warmup) % N + N) % N;
    extended.row(k) = u.row(source);
  }
  extended.bottomRows(N) = u;
  return simulate(ss, extended).bottomRows(N);
}

Eigen::MatrixXcd response(const MimoStateSpace& ss, double frequency, double fs) {
  check_shape(ss, "response");
  const std::complex<double> z = std::polar(1.0, 2.0 * std::numbers::pi * frequency / fs);
  const Eigen::Index n = ss.order();
  if (n == 0) return ss.D.cast<std::complex<double>>();
  const Eigen::MatrixXcd resolvent = z * Eigen::MatrixXcd::Identity(n, n) - ss.A.cast<std::complex<double>>();
  return ss.C.cast<std::complex<double>>() * resolvent.partialPivLu().solve(ss.B.cast<std::complex<double>>()) +
         ss.D.cast<std::complex<double>>();
}

}  // namespace panelbass::models

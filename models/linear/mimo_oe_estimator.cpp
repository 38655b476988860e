#include "models/linear/mimo_oe_estimator.h"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unsupported/Eigen/FFT>

#include "models/optimization/levenberg_marquardt.h"
#include "models/validation/performance.h"

namespace panelbass::models {
namespace {

using Complex = std::complex<double>;

/// Where each kind of parameter sits in θ.
struct ModalLayout {
  Eigen::Index pairs = 0, reals = 0, n = 0, m = 0, p = 0;
  Eigen::Index b = 0, c = 0, d = 0, size = 0;  ///< offsets of vec B, vec C, vec D; total

  explicit ModalLayout(const ModalStateSpace& model)
      : pairs(model.sigma.size()), reals(model.real_poles.size()), n(2 * pairs + reals), m(model.D.cols()),
        p(model.D.rows()) {
    b = 2 * pairs + reals;
    c = b + n * m;
    d = c + p * n;
    size = d + p * m;
  }
};

/// X = (zI − A)⁻¹·B·u and W = C·(zI − A)⁻¹ at one line, A block-diagonal (the resolvent block by block:
/// (zI − [[σ, ω], [−ω, σ]])⁻¹ = [[z−σ, ω], [−ω, z−σ]] / ((z−σ)² + ω²)).
void resolvent_terms(const ModalStateSpace& model, const ModalLayout& at, Complex z, const Eigen::VectorXcd& Bu,
                     Eigen::VectorXcd& X, Eigen::MatrixXcd* W) {
  for (Eigen::Index j = 0; j < at.pairs; ++j) {
    const Eigen::Index s = 2 * j;
    const Complex a = z - model.sigma[j];
    const double w = model.omega[j];
    const Complex inverse_det = 1.0 / (a * a + w * w);
    X[s] = (a * Bu[s] + w * Bu[s + 1]) * inverse_det;
    X[s + 1] = (-w * Bu[s] + a * Bu[s + 1]) * inverse_det;
    if (W != nullptr) {
      W->col(s) = (model.C.col(s).cast<Complex>() * a - model.C.col(s + 1).cast<Complex>() * w) * inverse_det;
      W->col(s + 1) = (model.C.col(s).cast<Complex>() * w + model.C.col(s + 1).cast<Complex>() * a) * inverse_det;
    }
  }
  for (Eigen::Index j = 0; j < at.reals; ++j) {
    const Eigen::Index s = 2 * at.pairs + j;
    const Complex inverse = 1.0 / (z - model.real_poles[j]);
    X[s] = Bu[s] * inverse;
    if (W != nullptr) W->col(s) = model.C.col(s).cast<Complex>() * inverse;
  }
}

/// Writes one complex column vector as real rows [Re; Im].
template <class Target>
void put_complex(Target&& target, const Eigen::VectorXcd& value) {
  const Eigen::Index p = value.size();
  target.head(p) = value.real();
  target.tail(p) = value.imag();
}

/// The residual rows (2p) of realisation r at line k, and (when J is given) their Jacobian rows (2p × P):
/// e = √w·(Y − C·X − D·u), de/dθ = −√w·d(G·u)/dθ with d(G·u)/dA = W·(dA)·X, d/dB_ij = W_:i·u_j,
/// d/dC_ij = e_i·X_j, d/dD_ij = e_i·u_j.
template <class Residual, class Jacobian>
void modal_line_rows(const ModalStateSpace& model, const ModalLayout& at, const PeriodicSpectra& data, std::size_t r,
               Eigen::Index k, Eigen::VectorXcd& Bu, Eigen::VectorXcd& X, Eigen::MatrixXcd& W, Residual&& e,
               Jacobian* J) {
  const Complex z = std::polar(1.0, 2.0 * std::numbers::pi * static_cast<double>(k) / static_cast<double>(data.period));
  const double root_w = std::sqrt(data.weight[k]);
  const Eigen::VectorXcd u = data.U[r].row(k).transpose();
  Bu.noalias() = model.B.cast<Complex>() * u;
  resolvent_terms(model, at, z, Bu, X, J != nullptr ? &W : nullptr);
  const Eigen::VectorXcd residual =
      root_w * (data.Y[r].row(k).transpose() - model.C.cast<Complex>() * X - model.D.cast<Complex>() * u);
  put_complex(e, residual);
  if (J == nullptr) return;
  auto column = [&](Eigen::Index index, const Eigen::VectorXcd& d_gu) { put_complex(J->col(index), (-root_w) * d_gu); };
  for (Eigen::Index j = 0; j < at.pairs; ++j) {
    const Eigen::Index s = 2 * j;
    column(2 * j, W.col(s) * X[s] + W.col(s + 1) * X[s + 1]);      // dA/dσ = I on the block
    column(2 * j + 1, W.col(s) * X[s + 1] - W.col(s + 1) * X[s]);  // dA/dω = [[0, 1], [−1, 0]]
  }
  for (Eigen::Index j = 0; j < at.reals; ++j) {
    const Eigen::Index s = 2 * at.pairs + j;
    column(2 * at.pairs + j, W.col(s) * X[s]);
  }
  for (Eigen::Index j = 0; j < at.m; ++j) {
    for (Eigen::Index i = 0; i < at.n; ++i) column(at.b + j * at.n + i, W.col(i) * u[j]);
  }
  Eigen::VectorXcd unit = Eigen::VectorXcd::Zero(at.p);
  for (Eigen::Index j = 0; j < at.n; ++j) {
    for (Eigen::Index i = 0; i < at.p; ++i) {
      unit.setZero();
      unit[i] = X[j];
      column(at.c + j * at.p + i, unit);
    }
  }
  for (Eigen::Index j = 0; j < at.m; ++j) {
    for (Eigen::Index i = 0; i < at.p; ++i) {
      unit.setZero();
      unit[i] = u[j];
      column(at.d + j * at.p + i, unit);
    }
  }
}

/// Checks that `model` and `data` agree in channels.
void check_modal_channels(const ModalStateSpace& model, const PeriodicSpectra& data, const char* where) {
  for (std::size_t r = 0; r < data.U.size(); ++r) {
    if (data.U[r].cols() != model.D.cols() || data.Y[r].cols() != model.D.rows()) {
      throw std::invalid_argument(std::string(where) + ": the data has " + std::to_string(data.U[r].cols()) + " inputs and " +
                                  std::to_string(data.Y[r].cols()) + " outputs, the model " + std::to_string(model.D.cols()) +
                                  " and " + std::to_string(model.D.rows()));
    }
  }
}

/// The loss Σ|e|² and, in H and g, JᵀJ and Jᵀe, accumulated over blocks of lines (J is never whole).
double modal_normal_equations(const ModalStateSpace& model, const PeriodicSpectra& data, Eigen::MatrixXd& H, Eigen::VectorXd& g) {
  const ModalLayout at(model);
  constexpr Eigen::Index kBlock = 256;  // lines per block
  const Eigen::Index lines = data.period / 2 + 1, rows = 2 * at.p;
  H.setZero(at.size, at.size);
  g.setZero(at.size);
  Eigen::MatrixXd J(kBlock * rows, at.size);
  Eigen::VectorXd e(kBlock * rows);
  Eigen::VectorXcd Bu(at.n), X(at.n);
  Eigen::MatrixXcd W(at.p, at.n);
  double loss = 0.0;
  for (std::size_t r = 0; r < data.U.size(); ++r) {
    for (Eigen::Index first = 0; first < lines; first += kBlock) {
      const Eigen::Index count = std::min(kBlock, lines - first);
      for (Eigen::Index i = 0; i < count; ++i) {
        auto Jrows = J.middleRows(i * rows, rows);
        modal_line_rows(model, at, data, r, first + i, Bu, X, W, e.segment(i * rows, rows), &Jrows);
      }
      const auto Jb = J.topRows(count * rows);
      const auto eb = e.head(count * rows);
      H.selfadjointView<Eigen::Lower>().rankUpdate(Jb.transpose());
      g.noalias() += Jb.transpose() * eb;
      loss += eb.squaredNorm();
    }
  }
  H.triangularView<Eigen::StrictlyUpper>() = H.transpose();
  return loss;
}

/// Σ|e|² alone.
double modal_loss(const ModalStateSpace& model, const PeriodicSpectra& data) {
  const ModalLayout at(model);
  Eigen::VectorXcd Bu(at.n), X(at.n);
  Eigen::MatrixXcd W;
  Eigen::VectorXd e(2 * at.p);
  double loss = 0.0;
  for (std::size_t r = 0; r < data.U.size(); ++r) {
    for (Eigen::Index k = 0; k <= data.period / 2; ++k) {
      modal_line_rows(model, at, data, r, k, Bu, X, W, e.head(2 * at.p), static_cast<Eigen::MatrixXd*>(nullptr));
      loss += e.squaredNorm();
    }
  }
  return loss;
}

double modal_j_pct(const ModalStateSpace& model, const PeriodicSpectra& data) {
  return j_ratio_percent(modal_loss(model, data), data.output_energy, "the measured outputs");
}

}  // namespace

PeriodicSpectra periodic_spectra(const std::vector<Eigen::MatrixXd>& u, const std::vector<Eigen::MatrixXd>& y) {
  if (u.empty() || u.size() != y.size()) {
    throw std::invalid_argument("periodic spectra: " + std::to_string(u.size()) + " input and " + std::to_string(y.size()) +
                                " output realisations");
  }
  PeriodicSpectra s;
  s.period = u.front().rows();
  if (s.period < 2) throw std::invalid_argument("periodic spectra: a period of " + std::to_string(s.period) + " samples");
  const Eigen::Index lines = s.period / 2 + 1;
  s.weight = Eigen::VectorXd::Constant(lines, 2.0 / static_cast<double>(s.period));
  s.weight[0] = 1.0 / static_cast<double>(s.period);
  if (s.period % 2 == 0) s.weight[lines - 1] = 1.0 / static_cast<double>(s.period);
  Eigen::FFT<double> fft;
  Eigen::VectorXcd spectrum;
  for (std::size_t r = 0; r < u.size(); ++r) {
    if (u[r].rows() != s.period || y[r].rows() != s.period || u[r].cols() != u.front().cols() ||
        y[r].cols() != y.front().cols()) {
      throw std::invalid_argument("periodic spectra: realisation " + std::to_string(r + 1) +
                                  " differs in length or channels from the first");
    }
    auto lines_of = [&](const Eigen::MatrixXd& x) {
      Eigen::MatrixXcd X(lines, x.cols());
      for (Eigen::Index c = 0; c < x.cols(); ++c) {
        const Eigen::VectorXd column = x.col(c);
        fft.fwd(spectrum, column);
        X.col(c) = spectrum.head(lines);
      }
      return X;
    };
    s.U.push_back(lines_of(u[r]));
    s.Y.push_back(lines_of(y[r]));
    s.output_energy += y[r].squaredNorm();
  }
  return s;
}

double steady_state_error(const MimoStateSpace& ss, const PeriodicSpectra& data) {
  return modal_loss(modal_form(ss), data);
}

MimoStateSpace ModalStateSpace::state_space() const {
  const ModalLayout at(*this);
  MimoStateSpace ss;
  ss.A = Eigen::MatrixXd::Zero(at.n, at.n);
  for (Eigen::Index j = 0; j < at.pairs; ++j) {
    ss.A(2 * j, 2 * j) = ss.A(2 * j + 1, 2 * j + 1) = sigma[j];
    ss.A(2 * j, 2 * j + 1) = omega[j];
    ss.A(2 * j + 1, 2 * j) = -omega[j];
  }
  for (Eigen::Index j = 0; j < at.reals; ++j) ss.A(2 * at.pairs + j, 2 * at.pairs + j) = real_poles[j];
  ss.B = B;
  ss.C = C;
  ss.D = D;
  return ss;
}

Eigen::VectorXd ModalStateSpace::theta() const {
  const ModalLayout at(*this);
  Eigen::VectorXd t(at.size);
  for (Eigen::Index j = 0; j < at.pairs; ++j) {
    t[2 * j] = sigma[j];
    t[2 * j + 1] = omega[j];
  }
  t.segment(2 * at.pairs, at.reals) = real_poles;
  t.segment(at.b, at.n * at.m) = B.reshaped();
  t.segment(at.c, at.p * at.n) = C.reshaped();
  t.segment(at.d, at.p * at.m) = D.reshaped();
  return t;
}

void ModalStateSpace::set_theta(const Eigen::VectorXd& t) {
  const ModalLayout at(*this);
  if (t.size() != at.size) {
    throw std::invalid_argument("modal state space: θ has " + std::to_string(t.size()) + " entries, expected " +
                                std::to_string(at.size));
  }
  for (Eigen::Index j = 0; j < at.pairs; ++j) {
    sigma[j] = t[2 * j];
    omega[j] = t[2 * j + 1];
  }
  real_poles = t.segment(2 * at.pairs, at.reals);
  B = t.segment(at.b, at.n * at.m).reshaped(at.n, at.m);
  C = t.segment(at.c, at.p * at.n).reshaped(at.p, at.n);
  D = t.segment(at.d, at.p * at.m).reshaped(at.p, at.m);
}

double ModalStateSpace::spectral_radius() const {
  double radius = 0.0;
  for (Eigen::Index j = 0; j < sigma.size(); ++j) radius = std::max(radius, std::hypot(sigma[j], omega[j]));
  if (real_poles.size() > 0) radius = std::max(radius, real_poles.cwiseAbs().maxCoeff());
  return radius;
}

ModalStateSpace modal_form(const MimoStateSpace& ss) {
  check_shape(ss, "modal form");
  const Eigen::Index n = ss.order();
  const Eigen::EigenSolver<Eigen::MatrixXd> eig(ss.A);
  if (eig.info() != Eigen::Success) throw std::invalid_argument("modal form: the eigenvalues of A did not converge");
  // A·(v_r + j·v_i) = (σ + jω)·(v_r + j·v_i) gives A·[v_r, v_i] = [v_r, v_i]·[[σ, ω], [−ω, σ]].
  std::vector<Eigen::Index> pairs, reals;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Complex lambda = eig.eigenvalues()[i];
    const double tolerance = 1e-10 * std::max(1.0, std::abs(lambda));
    if (std::abs(lambda.imag()) <= tolerance) {
      reals.push_back(i);
    } else if (lambda.imag() > 0.0) {
      pairs.push_back(i);
    }
  }
  if (static_cast<Eigen::Index>(2 * pairs.size() + reals.size()) != n) {
    throw std::invalid_argument("modal form: the complex eigenvalues of A do not come in conjugate pairs");
  }
  // A pole on or outside the unit circle is moved to radius min(1/|z|, 0.999) at the same angle.
  const auto inside = [](Complex z) {
    const double radius = std::abs(z);
    return radius < 1.0 ? z : z * (std::min(1.0 / radius, 0.999) / radius);
  };
  ModalStateSpace modal;
  modal.sigma.resize(static_cast<Eigen::Index>(pairs.size()));
  modal.omega.resize(static_cast<Eigen::Index>(pairs.size()));
  modal.real_poles.resize(static_cast<Eigen::Index>(reals.size()));
  Eigen::MatrixXd T(n, n);
  Eigen::Index column = 0;
  for (std::size_t j = 0; j < pairs.size(); ++j) {
    const Complex lambda = inside(eig.eigenvalues()[pairs[j]]);
    modal.sigma[static_cast<Eigen::Index>(j)] = lambda.real();
    modal.omega[static_cast<Eigen::Index>(j)] = lambda.imag();
    const Eigen::VectorXcd v = eig.eigenvectors().col(pairs[j]);
    T.col(column++) = v.real();
    T.col(column++) = v.imag();
  }
  for (std::size_t j = 0; j < reals.size(); ++j) {
    modal.real_poles[static_cast<Eigen::Index>(j)] = inside(eig.eigenvalues()[reals[j]]).real();
    T.col(column++) = eig.eigenvectors().col(reals[j]).real().normalized();
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(T);
  const Eigen::VectorXd& singular = svd.singularValues();
  if (!(singular[n - 1] > 1e-12 * singular[0])) {
    throw std::invalid_argument("modal form: A's eigenvectors are nearly dependent (a defective A, repeated poles)");
  }
  const auto lu = T.partialPivLu();
  modal.B = lu.solve(ss.B);
  modal.C = ss.C * T;
  modal.D = ss.D;
  return modal;
}

Eigen::VectorXd modal_residuals(const ModalStateSpace& model, const PeriodicSpectra& data) {
  check_modal_channels(model, data, "modal residuals");
  const ModalLayout at(model);
  const Eigen::Index lines = data.period / 2 + 1, rows = 2 * at.p;
  Eigen::VectorXd e(static_cast<Eigen::Index>(data.U.size()) * lines * rows);
  Eigen::VectorXcd Bu(at.n), X(at.n);
  Eigen::MatrixXcd W;
  for (std::size_t r = 0; r < data.U.size(); ++r) {
    for (Eigen::Index k = 0; k < lines; ++k) {
      modal_line_rows(model, at, data, r, k, Bu, X, W, e.segment((static_cast<Eigen::Index>(r) * lines + k) * rows, rows),
                static_cast<Eigen::MatrixXd*>(nullptr));
    }
  }
  return e;
}

Eigen::MatrixXd modal_jacobian(const ModalStateSpace& model, const PeriodicSpectra& data) {
  check_modal_channels(model, data, "modal jacobian");
  const ModalLayout at(model);
  const Eigen::Index lines = data.period / 2 + 1, rows = 2 * at.p;
  Eigen::MatrixXd J(static_cast<Eigen::Index>(data.U.size()) * lines * rows, at.size);
  Eigen::VectorXd e(rows);
  Eigen::VectorXcd Bu(at.n), X(at.n);
  Eigen::MatrixXcd W(at.p, at.n);
  for (std::size_t r = 0; r < data.U.size(); ++r) {
    for (Eigen::Index k = 0; k < lines; ++k) {
      auto block = J.middleRows((static_cast<Eigen::Index>(r) * lines + k) * rows, rows);
      modal_line_rows(model, at, data, r, k, Bu, X, W, e.head(rows), &block);
    }
  }
  return J;
}

MimoRefinement refine_mimo(const MimoStateSpace& start, const PeriodicSpectra& estimation,
                           const PeriodicSpectra& validation, const MimoRefinementOptions& options) {
  ModalStateSpace model = modal_form(start);
  check_modal_channels(model, estimation, "refine_mimo: estimation data");
  check_modal_channels(model, validation, "refine_mimo: validation data");
  const bool has_validation = !validation.U.empty();
  const auto selection_j = [&](const ModalStateSpace& m, double j_est) { return has_validation ? modal_j_pct(m, validation) : j_est; };

  LmSettings settings;
  settings.damping = LmDamping::relative_to_largest;
  settings.retries = 30;
  Eigen::VectorXd theta = model.theta();
  LevenbergMarquardt lm(settings, theta.size());
  Eigen::MatrixXd H;
  Eigen::VectorXd g;
  double V = modal_normal_equations(model, estimation, H, g);

  MimoRefinement out;
  MimoRefinementRecord record{0, j_ratio_percent(V, estimation.output_energy, "the measured outputs"), 0.0, lm.lambda()};
  record.j_val_pct = selection_j(model, record.j_est_pct);
  out.history.push_back(record);
  out.model = model.state_space();
  out.j_est_pct = record.j_est_pct;
  out.j_val_pct = record.j_val_pct;
  bool go_on = !options.progress || options.progress(record);

  ModalStateSpace candidate = model;
  for (int iteration = 1; go_on && iteration <= options.max_iterations; ++iteration) {
    const LmStep step = lm.step(H, g, V, theta, [&](const Eigen::VectorXd& trial) {
      candidate.set_theta(trial);
      if (!(candidate.spectral_radius() < 1.0)) return std::numeric_limits<double>::infinity();
      return modal_loss(candidate, estimation);
    });
    if (!step.accepted) break;
    model.set_theta(theta);
    V = modal_normal_equations(model, estimation, H, g);
    out.iterations = iteration;
    record = {iteration, j_ratio_percent(V, estimation.output_energy, "the measured outputs"), 0.0, lm.lambda()};
    record.j_val_pct = selection_j(model, record.j_est_pct);
    out.history.push_back(record);
    if (record.j_val_pct < out.j_val_pct) {
      out.model = model.state_space();
      out.best_iteration = iteration;
      out.j_est_pct = record.j_est_pct;
      out.j_val_pct = record.j_val_pct;
    }
    go_on = !options.progress || options.progress(record);
  }
  return out;
}

}  // namespace panelbass::models

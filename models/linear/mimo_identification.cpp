#include "models/linear/mimo_identification.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "models/linear/hankel_reduction.h"
#include "models/linear/periodic_impulse_response.h"

namespace panelbass::models {
namespace {

/// The RMS over every entry of every matrix.
double rms_over(const std::vector<Eigen::MatrixXd>& x) {
  double energy = 0.0, count = 0.0;
  for (const Eigen::MatrixXd& m : x) {
    energy += m.squaredNorm();
    count += static_cast<double>(m.size());
  }
  return count > 0.0 ? std::sqrt(energy / count) : 0.0;
}

std::vector<Eigen::MatrixXd> scaled_copies(const std::vector<Eigen::MatrixXd>& x, double factor) {
  std::vector<Eigen::MatrixXd> out;
  out.reserve(x.size());
  for (const Eigen::MatrixXd& m : x) out.push_back(m * factor);
  return out;
}

}  // namespace

int order_from_singular_values(const Eigen::VectorXd& sigma, int max_order) {
  int best = 1;
  double best_gap = -1.0;
  for (Eigen::Index n = 1; n < sigma.size() && n <= max_order; ++n) {
    if (!(sigma[n] > 0.0)) return static_cast<int>(n);  // exact rank n
    const double gap = sigma[n - 1] / sigma[n];
    if (gap > best_gap) {
      best_gap = gap;
      best = static_cast<int>(n);
    }
  }
  return best;
}

MimoIdentification identify_mimo(const std::vector<Eigen::MatrixXd>& u_est, const std::vector<Eigen::MatrixXd>& y_est,
                                 const std::vector<Eigen::MatrixXd>& u_val, const std::vector<Eigen::MatrixXd>& y_val,
                                 const MimoIdentificationSpec& spec) {
  if (u_est.empty()) throw std::invalid_argument("identify_mimo: no estimation realisations");
  const double su = rms_over(u_est), sy = rms_over(y_est);
  if (!(su > 0.0) || !(sy > 0.0)) throw std::invalid_argument("identify_mimo: the estimation input or output is silent");
  const std::vector<Eigen::MatrixXd> ue = scaled_copies(u_est, 1.0 / su), ye = scaled_copies(y_est, 1.0 / sy);
  const std::vector<Eigen::MatrixXd> uv = scaled_copies(u_val, 1.0 / su), yv = scaled_copies(y_val, 1.0 / sy);

  MimoIdentification out;
  // Thesis fig. 4.1, step 1: the impulse response (here p×m Markov parameters) by least squares.
  const std::vector<Eigen::MatrixXd> markov = estimate_periodic_impulse_response(ue, ye, spec.taps, spec.ridge);
  // Step 2: Kung's realisation; the order from the Hankel singular values unless given.
  Eigen::VectorXd sigma;
  int order = spec.order;
  if (order <= 0) {
    kung_realization(markov, 1, &sigma);
    order = order_from_singular_values(sigma, spec.max_auto_order);
  }
  const MimoStateSpace kung = kung_realization(markov, order, &sigma);
  out.hankel_singular_values = sigma;
  out.order = order;

  // Step 3: output error on the steady-state simulation, from Kung's model (in modal form, stabilised).
  const PeriodicSpectra est = periodic_spectra(ue, ye);
  const PeriodicSpectra val = uv.empty() ? PeriodicSpectra{} : periodic_spectra(uv, yv);
  MimoRefinementOptions options;
  options.max_iterations = spec.max_iterations;
  options.progress = spec.progress;
  out.refinement = refine_mimo(kung, est, val, options);
  out.kung_j_est_pct = out.refinement.history.front().j_est_pct;
  out.kung_j_val_pct = out.refinement.history.front().j_val_pct;

  // Back to raw units: u = su·ũ, y = sy·ỹ, so B = B̃/su, C = sy·C̃, D = sy·D̃/su.
  out.model = out.refinement.model;
  out.model.B /= su;
  out.model.C *= sy;
  out.model.D *= sy / su;
  return out;
}

}  // namespace panelbass::models

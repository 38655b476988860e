#include "models/optimization/evidence_decay.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <vector>

namespace panelbass::models {

double evidence_weight_decay(const Eigen::MatrixXd& regularised, double squared_error, double samples, double D,
                             const Eigen::VectorXd& theta, const Eigen::VectorXd& mask) {
  std::vector<Eigen::Index> free;
  for (Eigen::Index p = 0; p < theta.size(); ++p) {
    if (mask.size() == 0 || mask[p] != 0.0) free.push_back(p);
  }
  const auto P = static_cast<Eigen::Index>(free.size());
  double weights_squared = 0.0;
  for (const Eigen::Index p : free) weights_squared += theta[p] * theta[p];
  if (P == 0 || !(weights_squared > 0.0) || !std::isfinite(squared_error) || !(D >= 0.0)) return D;
  // γ = P − D·tr((JᵀJ + D·I)⁻¹): each direction counts by how much the data, not the prior, decide it
  double gamma = static_cast<double>(P);
  if (D > 0.0) {
    Eigen::MatrixXd A(P, P);
    for (Eigen::Index i = 0; i < P; ++i) {
      for (Eigen::Index j = 0; j < P; ++j) A(i, j) = regularised(free[i], free[j]);
    }
    const Eigen::LLT<Eigen::MatrixXd> llt(A);
    if (llt.info() != Eigen::Success) return D;
    // tr(A⁻¹) = ‖L⁻¹‖²_F for A = L·Lᵀ
    Eigen::MatrixXd inverse_factor = Eigen::MatrixXd::Identity(P, P);
    llt.matrixL().solveInPlace(inverse_factor);
    gamma -= D * inverse_factor.squaredNorm();
  }
  if (!(gamma > 0.0) || !(samples - gamma > 0.0)) return D;
  // D = α/β, α = γ/‖θ‖² the weights' prior precision, β = (N − γ)/Σe² the noise's
  const double updated = gamma * squared_error / ((samples - gamma) * weights_squared);
  return std::isfinite(updated) && updated > 0.0 ? updated : D;
}

}  // namespace panelbass::models

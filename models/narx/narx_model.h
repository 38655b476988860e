#pragma once
// The neural NARX model of the thesis ([5G]): y(k) = F(y(k−1..k−na), u(k−nk..k−nk−nb), θ), F an MLP.

#include <Eigen/Core>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/narx/mlp.h"
#include "models/preprocess/scaling.h"

namespace panelbass::models {

/// Which past outputs and inputs feed the network.
struct NarxStructure {
  int na = 8;              ///< past outputs y(k−1)..y(k−na)
  int nb = 8;              ///< past inputs: u(k−nk)..u(k−nk−nb), i.e. nb + 1 of them
  int nk = 0;              ///< input delay
  std::vector<int> hidden{17};  ///< hidden layer widths

  /// Inputs of the network: na + nb + 1.
  int inputs() const { return na + nb + 1; }
};

/// A NARX model in scaled units (thesis figs 5.1/5.2) with everything needed for raw data.
struct NarxModel {
  NarxStructure structure;
  Mlp net{17, {17}};
  Scaling scaling;
  double fs = 0.0;
  nlohmann::json meta = nlohmann::json::object();

  /// A model of `structure` with zero weights (call net.initialize()).
  static NarxModel with_structure(const NarxStructure& structure, const Scaling& scaling, double fs);

  /// Fills the regressor x(k) = [y(k−1)..y(k−na), u(k−nk)..u(k−nk−nb)] (scaled units) from `y_past`
  /// (the outputs used as the past: measured for prediction, simulated for simulation) and `u`;
  /// samples before the record count as 0.
  void regressor(const Eigen::VectorXd& u, const Eigen::VectorXd& y_past, Eigen::Index k,
                 Eigen::Ref<Eigen::VectorXd> x) const;

  /// Parallel (output-error) simulation in scaled units ([5H] OEM); the first `init` outputs are taken
  /// from `y` (scaled) instead of simulated.
  Eigen::VectorXd simulate_scaled(const Eigen::VectorXd& u, const Eigen::VectorXd& y = {}, Eigen::Index init = 0) const;
  /// Series-parallel one-step prediction in scaled units ([5H] PEM).
  Eigen::VectorXd predict_scaled(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const;

  /// Free-run simulation on raw data, raw output units; the first `init` measured outputs (raw) seed it.
  Eigen::VectorXd simulate(const Eigen::VectorXd& u, const Eigen::VectorXd& y = {}, Eigen::Index init = 0) const;
  /// One-step prediction on raw data, raw output units.
  Eigen::VectorXd predict(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const;
};

/// The model's small-signal response to the raw input u: its linearisation about its free run at rest (u = 0),
/// by the central difference (simulate(ε·u) − simulate(−ε·u)) / 2ε with ε·max|u| = 1e-5 raw units, so even
/// orders cancel and the odd ones leave a relative error of order (1e-5 / u_scale)². Raw output units,
/// without the rest output; all zeros for u = 0. Throws std::invalid_argument for a non-finite u.
Eigen::VectorXd small_signal_response(const NarxModel& m, const Eigen::VectorXd& u);

/// The same central difference of any model's free run `simulate` (raw drive → raw output from rest): what
/// small_signal_response computes of a NARX model, for the other kinds (the neural state-space model).
Eigen::VectorXd small_signal_response_of(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& simulate,
                                         const Eigen::VectorXd& u);

/// {"format":"panelbass.model/1","kind":"narx","fs","scaling","params":{"na","nb","nk","hidden","theta"},"meta"}.
nlohmann::json narx_model_to_json(const NarxModel& m);

/// Reads and validates a NARX model object: shapes (θ has exactly P entries for the structure), finite
/// weights, fs > 0, and a bounded free run (a simulation of 2000 samples of full-scale uniform noise
/// stays within ±100 in scaled units); ConfigError names the key or the problem.
NarxModel narx_model_from_json(const nlohmann::json& j);

}  // namespace panelbass::models

#pragma once
// The plant model in the neural feedback controller's loop (fig. 7.10): a NARX model ([5G]) or a neural
// state-space model (SUBNET, models/state_space_nn), in its own scaled units. The loop needs of it a step
// from rest given the drive — whole records with the forward sensitivities of its output for training
// (LoopPlantSweep), and sample by sample without allocating for the engine (LoopPlantRunner) — its
// scaling, rate and model file. Each kind is stepped by its own model code (the NARX network's forward
// pass, ss_step); nothing here repeats a recursion.
//
// The state-space model's loop starts from the state its encoder gives for a silent history (z = 0), the
// state SsModel::simulate starts from: so the loop with N1 = 0 is the plant model's own free run, and its
// rest output is the one the design subtracts (control_record), whereas x = 0 would start the loop with a
// transient of the model's offset wherever its equilibrium is not the origin.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <variant>

#include "models/narx/mlp.h"
#include "models/narx/narx_history.h"
#include "models/narx/narx_model.h"
#include "models/state_space_nn/ss_model.h"

namespace panelbass::models {

/// A plant model a neural feedback controller is designed on and runs in model mode.
struct LoopPlant {
  std::variant<NarxModel, SsModel> model;

  /// A NARX model with zero weights (the default of a controller before it has a plant).
  LoopPlant() = default;
  /// The NARX model `m`.
  LoopPlant(NarxModel m) : model(std::move(m)) {}  // NOLINT(google-explicit-constructor): a NARX model is a plant
  /// The neural state-space model `m`.
  LoopPlant(SsModel m) : model(std::move(m)) {}  // NOLINT(google-explicit-constructor): so is an ss model

  /// "narx" or "ss" (the kind of its model file).
  const char* kind() const;
  /// Sample rate, Hz.
  double fs() const;
  /// The scaling between raw and the model's scaled units.
  const Scaling& scaling() const;
  /// Free run from rest on the raw drive u, raw output units.
  Eigen::VectorXd simulate(const Eigen::VectorXd& u) const;
  /// Its small-signal response to the raw drive u (small_signal_response_of its free run).
  Eigen::VectorXd small_signal_response(const Eigen::VectorXd& u) const;
  /// Throws std::invalid_argument unless the model's parameters have the shape its structure says.
  void check() const;
};

/// The plant model's file ({"kind":"narx",…} or {"kind":"ss",…}).
nlohmann::json loop_plant_to_json(const LoopPlant& p);
/// Reads either kind's file by its "kind"; ConfigError naming the key (an unknown kind names model.kind).
LoopPlant loop_plant_from_json(const nlohmann::json& j);

/// The plant model stepped through whole records (scaled units), as training runs the loop: step(k) gives
/// ŷ_s(k) from the drives v_s(0..k) and, for NARX, the outputs ŷ_s(0..k−1); sensitivities(k) then adds the
/// forward sensitivities dŷ_s(k)/dθ1 from those of the drives and past outputs.
class LoopPlantSweep {
 public:
  /// A sweep of `plant` (kept by reference) for a controller of `parameters` parameters θ1.
  LoopPlantSweep(const LoopPlant& plant, Eigen::Index parameters);
  /// Back to rest (the NARX model's zero history, the ss model's encoder state for a silent past); the
  /// state's sensitivities to θ1 are zero there.
  void start();
  /// ŷ_s(k) for the scaled drives `v_scaled` (read up to k) and past outputs `y_scaled` (up to k − 1).
  double step(Eigen::Index k, const Eigen::VectorXd& v_scaled, const Eigen::VectorXd& y_scaled);
  /// After step(k): adds dŷ_s(k)/dθ1 to Dy.col(k) from Dv (P×N, columns up to k: dv(j)/dθ1, raw drive units)
  /// and Dy's earlier columns.
  void sensitivities(Eigen::Index k, const Eigen::MatrixXd& Dv, Eigen::MatrixXd& Dy);

 private:
  const LoopPlant& plant_;
  // NARX: the regressor and the network's derivatives
  Mlp::Workspace ws_;
  Eigen::VectorXd x_, dx_, dtheta_;
  // ss: the state before and after the step, the drive, and the state's sensitivities dx(k)/dθ1 (P×nx)
  SsStepWork work_;
  Eigen::MatrixXd state_, next_, jacobian_, Dx_, Dx_next_;
  Eigen::RowVectorXd drive_, output_;
  bool fresh_ = true;  // the next step is the first from rest
};

/// The plant model sample by sample for the engine (scaled units): sized once, then allocation-free.
class LoopPlantRunner {
 public:
  /// No plant.
  LoopPlantRunner() = default;
  /// At rest for `plant` (kept by reference); throws std::invalid_argument as LoopPlant::check.
  explicit LoopPlantRunner(const LoopPlant& plant);
  /// v_s(k) becomes the drive of the next output().
  void push_input(double v_scaled) noexcept;
  /// ŷ_s(k) for the drives so far; steps the model (call once per push_input()).
  double output() noexcept;
  /// Back to rest.
  void reset() noexcept;

 private:
  const LoopPlant* plant_ = nullptr;
  // NARX
  Mlp::Workspace ws_;
  NarxHistory history_;  // u_s(k..), ŷ_s(k−1..)
  // ss
  SsStepWork work_;
  Eigen::MatrixXd state_, next_, rest_;
  Eigen::RowVectorXd drive_, output_;
};

}  // namespace panelbass::models

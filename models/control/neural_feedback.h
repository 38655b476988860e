#pragma once
// The thesis's neural feedback controller (fig. 7.10, Appendix 3): a network N1 between the feedforward
// controller and the transducer that reads the feedforward output u, its own past drives v and the
// plant's past outputs y, so that the loop output tracks the desired (linear, flat) response:
//   v(k) = soft_limit(u(k) + N1(u(k..k−nu), v(k−1..k−nv), y(k−1..k−ny), θ1), knee).
// The skip term u(k) makes N1 = 0 the identity (the controller starts as "no feedback"); the soft limit
// keeps the drive within [−1, 1] by construction.
//
// Units: u and v are raw drive units; y enters N1 in the plant model's scaled units.
//
// The plant model in the loop is a NARX model or a neural state-space model (loop_plant.h).

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <vector>

#include "models/control/loop_plant.h"
#include "models/narx/mlp.h"
#include "models/narx/narx_history.h"

namespace panelbass::models {

/// Which signals feed N1.
struct FeedbackStructure {
  int nu = 2;                  ///< feedforward outputs u(k)..u(k−nu), i.e. nu + 1 of them
  int nv = 2;                  ///< past drives v(k−1)..v(k−nv)
  int ny = 4;                  ///< past plant outputs y(k−1)..y(k−ny)
  std::vector<int> hidden{8};  ///< hidden layer widths of N1
  /// Inputs of N1: nu + 1 + nv + ny.
  int inputs() const { return nu + 1 + nv + ny; }
};

/// A neural feedback controller and the plant model (NARX or state-space) it was designed on.
struct NeuralFeedback {
  FeedbackStructure structure;
  Mlp net{9, {8}};     ///< N1
  double knee = 0.8;   ///< the output soft limit's knee, in [0, 1)
  LoopPlant plant;     ///< the plant model (its scaling for y; run in model mode)
  double fs = 0.0;     ///< sample rate, Hz (the plant model's)
  nlohmann::json meta = nlohmann::json::object();  ///< provenance

  /// A controller of `structure` on `plant` with N1's weights zero (so v = soft_limit(u)); throws
  /// std::invalid_argument for negative orders or an empty/zero-width hidden layer.
  static NeuralFeedback with_structure(const FeedbackStructure& structure, const LoopPlant& plant);
  /// Fills N1's input r(k) = [u(k..k−nu), v(k−1..k−nv), y_s(k−1..k−ny)] from whole records (samples
  /// before the start count as 0); y_s in scaled units.
  void regressor(const Eigen::VectorXd& u, const Eigen::VectorXd& v, const Eigen::VectorXd& y_scaled,
                 Eigen::Index k, Eigen::Ref<Eigen::VectorXd> r) const;
};

/// What a closed-loop run of the controller with its plant model produced.
struct ClosedLoopRun {
  Eigen::VectorXd s;  ///< the unlimited controller output u + N1
  Eigen::VectorXd v;  ///< the drive, soft_limit(s)
  Eigen::VectorXd y;  ///< the plant model's output, raw units
};

/// The loop of fig. 7.10 on the plant model: for each k, v(k) from u(k) and the past, then the plant model's
/// output y(k) from the drives (its free run from rest, [5H] OEM). `u` in raw drive units.
ClosedLoopRun simulate_closed_loop(const NeuralFeedback& controller, const Eigen::VectorXd& u);

/// The controller sample by sample, for the engine: sized once, then allocation-free.
class FeedbackRunner {
 public:
  /// A runner at rest for `controller` (kept by reference: it must outlive the runner); throws
  /// std::invalid_argument unless N1 and the plant model have the parameters their structures say.
  explicit FeedbackRunner(const NeuralFeedback& controller);
  /// v(k) from u(k) and the histories; u(k) and v(k) become history.
  double control(double u) noexcept;
  /// The plant model's output ŷ(k) (raw) for the drives so far (model mode); call after control().
  double plant_model_output() noexcept;
  /// The plant output y(k) (raw; measured in sensor mode, ŷ in model mode) becomes history.
  void push_output(double y) noexcept;
  /// Every history back to 0.
  void reset() noexcept;
  /// u(k) + N1 of the last control(), before the soft limit: the drive the controller asked for.
  double asked() const noexcept { return asked_; }

 private:
  const NeuralFeedback& c_;
  Mlp::Workspace ws_;
  Eigen::VectorXd r_;
  SignalHistory u_hist_, v_hist_, y_hist_;  // newest first: u(k..), v(k−1..), y_s(k−1..)
  LoopPlantRunner plant_;                   // the plant model, stepped on the scaled drives
  double asked_ = 0.0;                      // u(k) + N1 before the soft limit
};

/// {"format":"panelbass.model/1","kind":"neural_feedback","fs",
///  "params":{"nu","nv","ny","hidden","knee","theta"},"plant":{…NARX or ss model file…},"meta"}.
nlohmann::json neural_feedback_to_json(const NeuralFeedback& c);
/// Reads and validates a neural feedback controller (shapes, finite weights, knee in [0, 1), the plant a
/// valid NARX or ss model, read by its kind, of the same fs); ConfigError names the key.
NeuralFeedback neural_feedback_from_json(const nlohmann::json& j);

}  // namespace panelbass::models

#pragma once
// The neural state-space model (SUBNET, Beintema et al. 2021/2023): a linear state space plus a small
// network in the state update and the output, its initial state from an encoder of past data.
//   x(k+1) = A·x(k) + B·u(k) + f(x(k), u(k)),   y(k) = C·x(k) + D·u(k) + h(x(k), u(k)),
//   [f; h] = W2·σ(W1·[x; u] + b1) + b2 + P·ζ(x, u),   x(k0) = E·z(k0) + V2·tanh(V1·z(k0) + c1) + c2,
// σ the nodes' activation: tanh, or the cube (a linear fractional / "nonlinear feedback" model: each node
// a cubic of one direction of [x; u] fed back through W2's column; with the states alone, W1's input
// column held at zero, the form of a cubic spring of one displacement, the Silverbox's Duffing physics),
// z(k) = [y(k−1) … y(k−L), u(k−1) … u(k−L)], everything in scaled units; ζ the monomials of [x; u] of
// total degree 2 … poly_degree (PNLSS, Paduart et al. 2010; none when poly_degree is 0), or of the states
// alone, or of the first poly_states states alone (the leading states of the balanced start: the dominant
// dynamics, e.g. a Duffing oscillator's pair, while the others stay linear).
// A model may instead fit its initial state per record (SsStatePrior, models/state_space_nn/ss_initial_state.h):
// x(0) chosen so that its own free run matches the record's first measured outputs, weighed against a
// Gaussian prior of its states.

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "models/linear/state_space.h"
#include "models/narx/free_run.h"
#include "models/preprocess/scaling.h"

namespace panelbass::models {

/// The activation σ of the state/output network's nodes.
enum class SsActivation {
  tanh,   ///< σ(a) = tanh(a): SUBNET's, bounded
  cubic,  ///< σ(a) = a³: with its bias, a cubic of one direction of [x; u] (z³, z², z and 1)
};

/// The sizes of a neural state-space model.
struct SsStructure {
  int states = 6;          ///< nx
  int hidden = 20;         ///< nodes of the state/output network [f; h]
  int lags = 50;           ///< L: past outputs and inputs the encoder reads
  int encoder_hidden = 0;  ///< tanh nodes of the encoder's network (0: an affine encoder)
  int poly_degree = 0;     ///< highest total degree of the polynomial ζ(x, u) in [f; h] (0: none, else 2–5)
  bool poly_input = true;  ///< ζ's monomials include the input (false: monomials of the states alone)
  int poly_states = 0;     ///< ζ's monomials are of the first poly_states states alone (0: of all nx states)
  SsActivation activation = SsActivation::tanh;  ///< σ of [f; h]'s nodes
  bool hidden_input = true;  ///< [f; h]'s nodes read the input (false: the states alone, W1's input column 0)

  /// Number of parameters P of θ.
  Eigen::Index parameter_count() const;
  /// Number of ζ's variables: poly_states when set (the leading states alone), else nx + 1 ([x; u]) or nx
  /// (without poly_input).
  int poly_variables() const;
  /// Number of monomials of ζ: those of poly_variables() variables of total degree 2 … poly_degree.
  Eigen::Index monomial_count() const;
  /// Throws std::invalid_argument naming the size out of range (states 1–64, hidden 0–1000 and at least 1
  /// without the polynomial, lags 1–1000, encoder_hidden 0–1000, poly_degree 0 or 2–5, poly_states 0–states,
  /// and poly_states > 0 only with the polynomial and without poly_input).
  void check() const;
};

/// The parts of θ as matrices, in the order θ stores them (each column-major): A (nx×nx), B (nx×1),
/// C (1×nx), D (1×1), W1 (hidden×(nx+1)), b1 (hidden), W2 ((nx+1)×hidden), b2 (nx+1), E (nx×2L),
/// c2 (nx), V1 (encoder_hidden×2L), c1 (encoder_hidden), V2 (nx×encoder_hidden), P ((nx+1)×monomials).
template <class Scalar>
struct SsParts {
  /// A map of a part of θ, writable when Scalar is not const.
  using Map = Eigen::Map<std::conditional_t<std::is_const_v<Scalar>, const Eigen::MatrixXd, Eigen::MatrixXd>>;
  Map A, B, C, D, W1, b1, W2, b2, E, c2, V1, c1, V2, P;
  int poly_degree = 0;  ///< ζ's highest degree (the structure's)
  int poly_variables = 0;  ///< ζ's variables: nx + 1 ([x; u]), nx (the states alone) or the leading poly_states
  SsActivation activation = SsActivation::tanh;  ///< σ of [f; h]'s nodes (the structure's)
  bool hidden_input = true;  ///< whether the nodes read the input (the structure's)
};

/// The parts of `theta` (size s.parameter_count(), not checked) for structure `s`.
SsParts<const double> ss_parts(const SsStructure& s, const double* theta);
/// The writable parts of `theta`.
SsParts<double> ss_parts(const SsStructure& s, double* theta);

/// The workspace of ss_step and ss_encode for batches of `columns` sequences.
struct SsStepWork {
  Eigen::MatrixXd pre;        ///< W1·[x; u] + b1, hidden × columns (the nodes' inputs)
  Eigen::MatrixXd hidden;     ///< σ(pre), hidden × columns
  Eigen::MatrixXd network;    ///< [f; h], (nx+1) × columns
  Eigen::MatrixXd monomials;  ///< ζ(x, u), monomials × columns
  std::vector<std::vector<int>> factors;  ///< ζ's monomials, each as the indices into [x; u] of its factors
};

/// The monomials of `variables` variables of total degree 2 … `degree`, each as the (non-decreasing)
/// indices of its factors, degree by degree; empty for degree 0.
std::vector<std::vector<int>> ss_monomial_factors(int variables, int degree);

/// ζ of the columns of [X; U] (X nx×B, U 1×B) into `out` (monomials×B).
void ss_monomials(const std::vector<std::vector<int>>& factors, const Eigen::Ref<const Eigen::MatrixXd>& X,
                  const Eigen::Ref<const Eigen::RowVectorXd>& U, Eigen::MatrixXd& out);

/// Back-propagation through ζ: adds Σ_m Q(m, b)·∂ζ_m/∂x_i at column b of [X; U] to dX(i, b), i < nx.
void ss_monomials_backward(const std::vector<std::vector<int>>& factors, const Eigen::Ref<const Eigen::MatrixXd>& X,
                           const Eigen::Ref<const Eigen::RowVectorXd>& U, const Eigen::MatrixXd& Q,
                           Eigen::Ref<Eigen::MatrixXd> dX);

/// σ(pre) into `out` (resized to pre's shape).
void ss_activate(SsActivation activation, const Eigen::MatrixXd& pre, Eigen::MatrixXd& out);
/// σ′ at the nodes' inputs `pre`, their outputs `out` = σ(pre) given: 1 − out² (tanh), 3·pre² (cube).
Eigen::ArrayXXd ss_activation_slope(SsActivation activation, const Eigen::Ref<const Eigen::MatrixXd>& pre,
                                    const Eigen::Ref<const Eigen::MatrixXd>& out);
/// "tanh" or "cubic".
const char* ss_activation_name(SsActivation activation);
/// The activation named `name` ("tanh", "cubic"); std::invalid_argument naming it otherwise.
SsActivation ss_activation_from_name(const std::string& name);

/// One step of `columns` sequences at once ([f; h] and the recursion of the header): from states X (nx×B)
/// and inputs U (1×B), the outputs Y (1×B) and next states X_next (nx×B); work.pre and work.hidden keep
/// the nodes' inputs and outputs for back-propagation.
void ss_step(const SsParts<const double>& p, const Eigen::Ref<const Eigen::MatrixXd>& X,
             const Eigen::Ref<const Eigen::RowVectorXd>& U, SsStepWork& work, Eigen::Ref<Eigen::RowVectorXd> Y,
             Eigen::Ref<Eigen::MatrixXd> X_next);

/// [f; h] at one state x (nx) and input u, and into `jacobian` its Jacobian ∂[f; h]/∂[x; u] ((nx+1)×(nx+1)),
/// exact (σ′ and the polynomial's derivatives); `factors` are ζ's monomials (ss_monomial_factors). Allocates:
/// for analysis and training, not the real-time path.
Eigen::VectorXd ss_network_jacobian(const SsParts<const double>& p, const Eigen::VectorXd& x, double u,
                                    const std::vector<std::vector<int>>& factors, Eigen::MatrixXd& jacobian);

/// The encoder's states X0 (nx×B) from regressors Z (2L×B); `hidden` receives its tanh layer
/// (encoder_hidden×B).
void ss_encode(const SsParts<const double>& p, const Eigen::Ref<const Eigen::MatrixXd>& Z, Eigen::MatrixXd& hidden,
               Eigen::Ref<Eigen::MatrixXd> X0);

/// The encoder's regressor z(k) = [y(k−1) … y(k−L), u(k−1) … u(k−L)] into `z` (size 2L); samples before
/// the record count as 0 (the scaled mean).
void ss_regressor(const Eigen::VectorXd& u, const Eigen::VectorXd& y, Eigen::Index k, int lags,
                  Eigen::Ref<Eigen::VectorXd> z);

/// What fitting a record's initial state weighs the first measured outputs against (scaled units): the
/// states' mean and covariance along the model's free run on its estimation data, and the variance of that
/// free run's output error there.
struct SsStatePrior {
  Eigen::VectorXd mean;        ///< nx
  Eigen::MatrixXd covariance;  ///< nx × nx, symmetric positive semi-definite
  double noise_variance = 0.0; ///< > 0
};

/// A neural state-space model in scaled units, with what it needs for raw data.
struct SsModel {
  SsStructure structure;
  Eigen::VectorXd theta;  ///< parameters, laid out as SsParts says
  Scaling scaling;
  double fs = 0.0;
  nlohmann::json meta = nlohmann::json::object();
  /// Set: a free run with measured outputs fits x(0) to them (ss_fit_initial_state) instead of encoding
  /// x(init) from them; the encoder still serves one-step prediction and training windows.
  std::optional<SsStatePrior> state_prior;

  /// The linear part (A, B, C, D).
  StateSpace linear_part() const;
  /// The linearisation at the equilibrium of zero scaled input (the data's mean): x* = A·x* + f(x*, 0) found
  /// by Newton from x = 0, then A + ∂f/∂x, B + ∂f/∂u, C + ∂h/∂x, D + ∂h/∂u there, exact (the tanh layer's and
  /// the polynomial's derivatives). Scaled units. Throws std::invalid_argument when no equilibrium is found.
  StateSpace linearization() const;

  /// Free run in scaled units: outputs before `init` are the measured ones, the encoder reads the record
  /// before `init` (zeros before its start) for x(init), and the recursion runs from there. With a
  /// state_prior and init > 0, x(0) is fitted to the first `init` outputs and the recursion runs from k = 0.
  Eigen::VectorXd simulate_scaled(const Eigen::VectorXd& u, const Eigen::VectorXd& y = {}, Eigen::Index init = 0) const;
  /// The recursion from state x0 at sample `begin` to `end` (exclusive) on scaled input u: the outputs of
  /// those samples; `states`, when given, receives x(k) of each (nx × (end − begin)).
  Eigen::VectorXd run_scaled(const Eigen::VectorXd& u, const Eigen::VectorXd& x0, Eigen::Index begin, Eigen::Index end,
                             Eigen::MatrixXd* states = nullptr) const;
  /// One-step prediction in scaled units: at every k the encoder's state from the measured past, then h.
  Eigen::VectorXd predict_scaled(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const;
  /// Free run on raw data, raw units; the first `init` measured outputs (raw) seed it.
  Eigen::VectorXd simulate(const Eigen::VectorXd& u, const Eigen::VectorXd& y = {}, Eigen::Index init = 0) const;
  /// One-step prediction on raw data, raw units.
  Eigen::VectorXd predict(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const;
};

/// A model of structure `s` that is exactly the linear `linear` (nx = its order, which s.states is set to):
/// A, B, C, D from it, W1 and b1 uniform random scaled by `state_scale` (the typical size of each state,
/// nx entries) and the input's 1 (0 without hidden_input), W2 = b2 = 0, the encoder zero except V1 and c1, random. Seeded.
SsModel ss_model_from_linear(const StateSpace& linear, SsStructure s, const Eigen::VectorXd& state_scale,
                             const Scaling& scaling, double fs, std::uint64_t seed);

/// {"format":"panelbass.model/1","kind":"ss","fs","scaling","params":{"states","hidden","lags",
/// "encoder_hidden","poly_degree","poly_input","poly_states","activation","hidden_input","theta",
/// "initial_state":{"state_mean","state_covariance" (column-major),"noise_variance"}},"meta"}
/// (poly_degree and poly_states optional on reading, 0 when absent; poly_input optional, true when absent
/// unless poly_states > 0; hidden_input optional, true when absent; activation "tanh" or "cubic", "tanh"
/// when absent; initial_state optional, the encoder's when absent).
nlohmann::json ss_model_to_json(const SsModel& m);

/// The runaway of `m`'s free run (scaled units, from rest) on free_run_drive(); nullopt when it stays within
/// ±kFreeRunBound. The loader's test, and the trainers' test of every model they would return.
std::optional<Runaway> ss_free_run_runaway(const SsModel& m);

/// Reads and validates a neural state-space model object: sizes, θ of exactly P finite entries, fs > 0, and
/// a bounded free run (ss_free_run_runaway); ConfigError names the key.
SsModel ss_model_from_json(const nlohmann::json& j);
/// ss_model_from_json without the free-run test: the file's shape alone (the API tells an unstable model
/// from a malformed one by running that test itself).
SsModel ss_model_shape_from_json(const nlohmann::json& j);

}  // namespace panelbass::models

#pragma once
// `identify ss` / the identify-ss job: the neural state-space model (SUBNET, models/state_space_nn) from the best
// linear model (an OE fit of order nx, a given linear model, or a Wiener–Hammerstein split of it), trained by Adam
// on simulation windows and optionally polished by L-BFGS, the model of the lowest selection J kept.

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "models/linear/linear_model.h"
#include "models/state_space_nn/ss_model.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// What `identify ss` is asked.
struct IdentifySsRequest {
  Eigen::VectorXd u_est, y_est;  ///< estimation record, raw
  Eigen::VectorXd u_val, y_val;  ///< validation record (empty: none; selection on the estimation record)
  double fs = 0.0;               ///< Hz
  std::string data_name, val_name;  ///< where the records came from, kept in the model's meta
  std::optional<models::LinearModel> linear;  ///< the linear start (none: OE of order nx on the estimation record)
  std::string linear_name;                    ///< where it came from
  std::optional<models::SsModel> start_from;  ///< an ss model trained on from where it is (its sizes kept)
  std::string start_from_name;                ///< where it came from
  int nx = 6;               ///< states: the order of the OE start (without a linear start), 1..64
  int nk = -1;              ///< input delay of the OE start (-1: estimated), -1..1000
  int hidden = 20;          ///< tanh nodes of the state/output network, 0..1000
  int poly_degree = 0;      ///< PNLSS's polynomial of [x; u] up to this degree (0: none, else 2..5)
  int poly_states = 0;      ///< the polynomial's monomials of the leading states alone (0: all), 0..64
  bool poly_states_only = false;    ///< the polynomial's monomials of the states alone
  std::string activation = "tanh";  ///< the nodes' activation: tanh or cubic
  bool hidden_states_only = false;  ///< the nodes read the states alone, not the input
  bool wiener_hammerstein = false;  ///< start from a Wiener–Hammerstein split of the linear start
  int wh_iterations = 200;  ///< Levenberg–Marquardt iterations refining that start, 0..100000
  int wh_candidates = 1;    ///< splits refined before the best one is kept, 1..64
  int lags = 50;            ///< past inputs and outputs the encoder reads, 1..1000
  int encoder_hidden = 0;   ///< tanh nodes of the encoder (0: affine), 0..1000
  long window = 100;        ///< samples simulated per training window, 1..100000
  long batch = 32;          ///< windows per Adam step, 1..100000
  int epochs = 100;         ///< most epochs, 0..1000000
  double max_seconds = 0.0;  ///< Adam stops after this many seconds, the polish at twice that (0: no limit)
  int patience = 0;         ///< epochs without a better J before stopping (0: never)
  double learning_rate = 1e-3;        ///< Adam's, (0, 1]
  double final_learning_rate = 0.0;   ///< reached at the last epoch by geometric decay (0: constant), [0, 1]
  int polish_iterations = 0;  ///< L-BFGS iterations after Adam (0: none)
  long polish_window = 0;     ///< window of the polish (0: window)
  std::string initial_state;  ///< "encoder", "fit", or "" (the encoder, or start_from's own)
  long init = 50;             ///< measured samples that set the state before J
  std::uint64_t seed = 1;     ///< initial weights and window draws
};

/// What `identify ss` made.
struct IdentifySsReport {
  models::SsModel model;      ///< its meta filled in
  nlohmann::json summary;     ///< {"J_est_pct","J_val_pct","start_J_pct","initial_state","states","params",…}
  nlohmann::json history;     ///< the selection J of every epoch and L-BFGS iteration
  std::vector<std::string> warnings;  ///< what the user should know (a fit no better than an output of zero)
};

/// Throws RequestError naming the field for a request out of range or inconsistent.
void check(const IdentifySsRequest& request);

/// The request's fields (the records and models by their names), as the API echoes its params.
nlohmann::json to_json(const IdentifySsRequest& request);

/// Trains the model; std::runtime_error when every candidate's free run leaves the bound (no model to write).
IdentifySsReport identify_ss(const IdentifySsRequest& request, Progress& progress);

}  // namespace panelbass::usecases

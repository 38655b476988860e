#include "usecases/identify_ss.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "models/io/json_fields.h"
#include "models/io/number_text.h"
#include "models/linear/fit_warnings.h"
#include "models/linear/linear_identification.h"
#include "models/state_space_nn/ss_initial_state.h"
#include "models/state_space_nn/ss_training.h"
#include "models/state_space_nn/ss_wiener_hammerstein.h"
#include "models/validation/performance.h"
#include "usecases/request_checks.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

using nlohmann::json;

// The structure of the network around the linear start, from the request.
models::SsStructure structure_of(const IdentifySsRequest& q) {
  models::SsStructure s;
  s.hidden = q.hidden;
  s.lags = q.lags;
  s.encoder_hidden = q.encoder_hidden;
  s.poly_degree = q.poly_degree;
  s.poly_input = !q.poly_states_only && q.poly_states == 0;
  s.poly_states = q.poly_states;
  s.activation = models::ss_activation_from_name(q.activation);
  s.hidden_input = !q.hidden_states_only;
  return s;
}

// The linear start: the request's, else OE of order nx fitted on the estimation record.
models::LinearModel starting_linear(const IdentifySsRequest& q, Progress& progress) {
  if (q.linear) return *q.linear;
  models::LinearIdentificationSpec spec;
  spec.method = models::LinearMethod::oe;
  spec.order = q.nx;
  spec.delay = q.nk;
  spec.init = q.init;
  spec.fs = q.fs;
  progress.report(0.0, "linear start: OE of order " + std::to_string(q.nx));
  return models::identify_linear(q.u_est, q.y_est, q.u_val, q.y_val, spec).model;
}

// One epoch or L-BFGS iteration in the history.
json history_entry(const char* counter, const models::SsTrainingRecord& r, double seconds) {
  return {{counter, r.epoch},
          {"loss", models::number_or_null(r.loss)},
          {"J_sel_pct", models::number_or_null(r.j_val_pct)},
          {"seconds", seconds}};
}

}  // namespace

void check(const IdentifySsRequest& q) {
  within("nx", q.nx, 1, 64);
  within("nk", q.nk, -1, 1000);
  within("hidden", q.hidden, 0, 1000);
  if (q.poly_degree != 0 && (q.poly_degree < 2 || q.poly_degree > 5)) {
    throw RequestError("poly_degree", "must be 0 (none) or 2..5, got " + std::to_string(q.poly_degree));
  }
  within("poly_states", q.poly_states, 0, 64);
  if (q.activation != "tanh" && q.activation != "cubic") {
    throw RequestError("activation", "must be tanh or cubic, got \"" + q.activation + "\"");
  }
  within("wh_iterations", q.wh_iterations, 0, 100000);
  within("wh_candidates", q.wh_candidates, 1, 64);
  within("lags", q.lags, 1, 1000);
  within("encoder_hidden", q.encoder_hidden, 0, 1000);
  within("window", q.window, 1, 100000);
  within("batch", q.batch, 1, 100000);
  within("epochs", q.epochs, 0, 1000000);
  within_real("max_seconds", q.max_seconds, 0.0, 1e7);
  within("patience", q.patience, 0, 1000000);
  within_real("learning_rate", q.learning_rate, 1e-9, 1.0);
  within_real("final_learning_rate", q.final_learning_rate, 0.0, 1.0);
  within("polish_iterations", q.polish_iterations, 0, 1000000);
  within("polish_window", q.polish_window, 0, 10000000);
  if (!q.initial_state.empty() && q.initial_state != "encoder" && q.initial_state != "fit") {
    throw RequestError("initial_state", "must be encoder or fit, got \"" + q.initial_state + "\"");
  }
  within("init", q.init, 0, 100000000);
  if (q.u_est.size() != q.y_est.size() || q.u_val.size() != q.y_val.size()) {
    throw RequestError("record", "a part's drive and response differ in length");
  }
  // (A request without its record yet — the API's params, checked before the record is made — skips this.)
  if (!q.start_from && q.u_est.size() > 0 && q.u_est.size() < q.lags + q.window) {
    throw RequestError("record", std::to_string(q.u_est.size()) + " estimation samples, lags + window = " +
                                     std::to_string(q.lags + q.window) + " needed");
  }
  if (q.wiener_hammerstein && q.hidden < 1) {
    throw RequestError("wiener_hammerstein", "needs hidden >= 1: the tanh nodes of the static nonlinearity");
  }
  if (q.wiener_hammerstein && (q.activation != "tanh" || q.hidden_states_only)) {
    throw RequestError("wiener_hammerstein", "takes neither the cubic activation nor hidden_states_only: its nodes are "
                                             "tanh nodes of the front filter's output");
  }
  if (q.poly_states > 0 && q.poly_degree == 0) {
    throw RequestError("poly_states", "needs poly_degree: the monomials it restricts");
  }
  if (q.poly_states > 0 && !q.linear && q.poly_states > q.nx) {
    throw RequestError("poly_states", std::to_string(q.poly_states) + " exceeds nx " + std::to_string(q.nx) +
                                          ": the monomials are of the leading states, at most all of them");
  }
  if (q.linear && q.linear->fs != q.fs) {
    throw RequestError("linear", "identified at " + models::number_text(q.linear->fs) + " Hz, the data is at " +
                                     models::number_text(q.fs) + " Hz");
  }
  if (q.start_from && q.start_from->fs != q.fs) {
    throw RequestError("start_from", "identified at " + models::number_text(q.start_from->fs) + " Hz, the data is at " +
                                         models::number_text(q.fs) + " Hz");
  }
}

json to_json(const IdentifySsRequest& q) {
  return {{"record", q.data_name},
          {"val", q.val_name},
          {"linear", q.linear_name},
          {"start_from", q.start_from_name},
          {"nx", q.nx},
          {"nk", q.nk},
          {"hidden", q.hidden},
          {"poly_degree", q.poly_degree},
          {"poly_states", q.poly_states},
          {"poly_states_only", q.poly_states_only},
          {"activation", q.activation},
          {"hidden_states_only", q.hidden_states_only},
          {"wiener_hammerstein", q.wiener_hammerstein},
          {"wh_iterations", q.wh_iterations},
          {"wh_candidates", q.wh_candidates},
          {"lags", q.lags},
          {"encoder_hidden", q.encoder_hidden},
          {"window", q.window},
          {"batch", q.batch},
          {"epochs", q.epochs},
          {"max_seconds", q.max_seconds},
          {"patience", q.patience},
          {"learning_rate", q.learning_rate},
          {"final_learning_rate", q.final_learning_rate},
          {"polish_iterations", q.polish_iterations},
          {"polish_window", q.polish_window},
          {"initial_state", q.initial_state},
          {"init", q.init},
          {"seed", q.seed}};
}

IdentifySsReport identify_ss(const IdentifySsRequest& q, Progress& progress) {
  check(q);
  const auto began = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count(); };
  const bool validated = q.u_val.size() > 0;
  const char* selection = validated ? "J_val" : "J_est";
  models::SsModel start;
  json wh_start = nullptr;
  if (q.start_from) {
    start = *q.start_from;
  } else {
    const models::SsStructure structure = structure_of(q);
    const models::LinearModel linear = starting_linear(q, progress);
    if (q.wiener_hammerstein) {
      progress.report(0.0, "Wiener-Hammerstein start");
      const models::SsWienerHammerstein wh = models::ss_wiener_hammerstein_start(
          linear, structure, q.u_est, q.y_est, q.u_val, q.y_val, q.wh_iterations, q.seed, q.wh_candidates);
      start = wh.model;
      wh_start = {{"splits", wh.splits},
                  {"front_poles", wh.front_poles},
                  {"front_zeros", wh.front_zeros},
                  {"front_states", wh.front_states},
                  {"search_J_from_rest_pct", wh.search_j_pct},
                  {"J_from_rest_pct", wh.j_pct},
                  {"iterations", wh.iterations},
                  {"candidates", wh.candidates},
                  {"linear_J_from_rest_pct", wh.linear_j_pct}};
    } else {
      start = models::ss_initial_model(linear, structure, q.u_est, q.y_est, q.seed);
    }
  }

  // The initial state: the encoder's, or fitted per record against the prior of the start's states (the
  // selection's J is then the fitted one, as the written model's is; the prior is the kept model's in the file).
  const bool fit_initial_state = q.initial_state == "fit" || (q.initial_state.empty() && start.state_prior);
  const std::string initial_state = fit_initial_state ? "fit" : "encoder";
  auto set_prior = [&](models::SsModel& m) {
    m.state_prior.reset();
    if (fit_initial_state) m.state_prior = models::ss_state_prior(m, q.u_est, q.y_est, q.init);
  };
  set_prior(start);

  models::SsTrainingOptions options;
  options.window = q.window;
  options.batch = q.batch;
  options.max_epochs = q.epochs;
  options.patience = q.patience;
  options.adam.learning_rate = q.learning_rate;
  options.final_learning_rate = q.final_learning_rate;
  options.init = q.init;
  options.seed = q.seed;
  IdentifySsReport report;
  report.history = json::array();
  const double adam_share = q.polish_iterations > 0 ? 0.7 : 1.0;
  options.progress = [&](const models::SsTrainingRecord& r) {
    report.history.push_back(history_entry("epoch", r, seconds()));
    progress.report(adam_share * r.epoch / std::max(1, q.epochs),
                    "epoch " + std::to_string(r.epoch) + ": " + selection + " " + models::number_text(r.j_val_pct) + " %");
    return !progress.stopping() && !(q.max_seconds > 0.0 && seconds() >= q.max_seconds);
  };
  models::SsTraining trained = models::train_ss(start, q.u_est, q.y_est, q.u_val, q.y_val, options);
  const double j_start = trained.history.front().j_val_pct;
  int polish_status = 0;
  if (q.polish_iterations > 0 && !progress.stopping()) {
    models::SsPolishOptions polish;
    polish.window = q.polish_window > 0 ? q.polish_window : q.window;
    polish.iterations = q.polish_iterations;
    polish.init = q.init;
    polish.progress = [&](const models::SsTrainingRecord& r) {
      report.history.push_back(history_entry("lbfgs_iteration", r, seconds()));
      progress.report(adam_share + (1.0 - adam_share) * r.epoch / q.polish_iterations,
                      "L-BFGS iteration " + std::to_string(r.epoch) + ": " + selection + " " +
                          models::number_text(r.j_val_pct) + " %");
      return !progress.stopping() && !(q.max_seconds > 0.0 && seconds() >= 2.0 * q.max_seconds);
    };
    const models::SsTraining polished = models::polish_ss(trained.model, q.u_est, q.y_est, q.u_val, q.y_val, polish);
    polish_status = polished.status;
    trained.model = polished.model;
    trained.j_val_pct = polished.j_val_pct;
    trained.runaway = polished.runaway;
  }
  if (trained.runaway) {
    throw std::runtime_error(
        "the free run of every candidate (the start, " + std::to_string(trained.history.size() - 1) + " epochs" +
        (q.polish_iterations > 0 ? " and the L-BFGS iterates" : "") + ") left the bound on full-scale noise (the start's |y| = " +
        models::number_text(trained.runaway->magnitude) + " after " + std::to_string(trained.runaway->samples) +
        " samples, scaled units), so no reader would load it. Try fewer states (nx), a lower poly_degree, "
        "without poly_states_only, a lower learning_rate, or more estimation data");
  }
  if (fit_initial_state && trained.model.theta != start.theta) {
    set_prior(trained.model);
    if (validated) trained.j_val_pct = models::j_percent(trained.model.simulate(q.u_val, q.y_val, q.init), q.y_val, q.init);
  }
  const double j_est = models::j_percent(trained.model.simulate(q.u_est, q.y_est, q.init), q.y_est, q.init);
  const double j_val = validated ? trained.j_val_pct : NAN;
  const int epochs = static_cast<int>(trained.history.size()) - 1;
  trained.model.meta = {{"data", q.data_name},
                        {"val", q.val_name},
                        {"linear", q.linear_name},
                        {"init", q.init},
                        {"initial_state", initial_state},
                        {"J_est_pct", j_est},
                        {"J_val_pct", models::number_or_null(j_val)},
                        {"start_J_pct", j_start},
                        {"wiener_hammerstein_start", wh_start},
                        {"epochs", epochs},
                        {"best_epoch", trained.best_epoch},
                        {"seconds", seconds()}};
  report.summary = {{"J_est_pct", j_est},
                    {"J_val_pct", models::number_or_null(j_val)},
                    {"start_J_pct", j_start},
                    {"initial_state", initial_state},
                    {"wiener_hammerstein_start", wh_start},
                    {"states", trained.model.structure.states},
                    {"params", trained.model.theta.size()},
                    {"epochs", epochs},
                    {"best_epoch", trained.best_epoch},
                    {"polish_status", q.polish_iterations > 0 ? json(polish_status) : json(nullptr)},
                    {"seconds", seconds()}};
  report.warnings = models::fit_warnings(validated ? j_val : j_est, selection, NAN,
                                         "Try more epochs, a Wiener-Hammerstein start, another nx, or more estimation data.");
  report.model = std::move(trained.model);
  progress.report(1.0, "done");
  return report;
}

}  // namespace panelbass::usecases

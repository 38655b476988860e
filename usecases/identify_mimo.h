#pragma once
// `identify mimo` / the identify-mimo job: a multi-input multi-output linear state space from periodic
// steady-state records (models/linear/mimo_identification: FIR on circular regressors → Kung's realisation →
// Levenberg–Marquardt on the simulation error), the last realisations of each record held out to select.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dsp/periodic_record.h"
#include "models/linear/mimo_model.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// What `identify mimo` is asked.
struct IdentifyMimoRequest {
  std::vector<dsp::PeriodicRecord> records;  ///< periodic records of the same inputs, outputs and period, pooled
  std::vector<std::string> record_names;     ///< where each came from, as long as `records`
  std::vector<std::string> inputs{"u1", "u2", "u3"}, outputs{"y1", "y2", "y3"};  ///< the columns read
  double fs = 0.0;              ///< Hz, > 0
  int order = 0;                ///< states (0: at the largest gap of the Hankel singular values), 0..200
  long taps = 150;              ///< Markov parameters estimated before Kung's realisation, 3..100000
  double ridge = 1e-6;          ///< ridge of the FIR's normal equations, relative to their mean diagonal, [0, 1]
  int max_iterations = 100;     ///< Levenberg–Marquardt iterations at most (0: Kung's model), 0..100000
  long val_realizations = 1;    ///< realisations at the end of every record held out to select, 0..1000
};

/// What `identify mimo` made.
struct IdentifyMimoReport {
  models::MimoModel model;            ///< its meta filled in
  nlohmann::json summary;             ///< {"order","inputs","outputs","J_est_pct","J_val_pct","kung_J_…",…,"history"}
  std::vector<std::string> warnings;  ///< a fit no better than an output of zero
};

/// Throws RequestError naming the field for a request out of range or records that do not pool ("record").
void check(const IdentifyMimoRequest& request);

/// The request's fields (the records by their names), as the API echoes its params.
nlohmann::json to_json(const IdentifyMimoRequest& request);

/// Identifies the model.
IdentifyMimoReport identify_mimo(const IdentifyMimoRequest& request, Progress& progress);

}  // namespace panelbass::usecases

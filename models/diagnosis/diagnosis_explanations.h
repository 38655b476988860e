#pragma once
// Diagnosis, step three: a kept augmentation in words — the physics it adds, the evidence for it — and its
// terms as JSON. Folder-internal (namespace diagnosis_detail), used by the driver (diagnosis.cpp).

#include <nlohmann/json.hpp>
#include <string>

#include "models/diagnosis/diagnosis_candidates.h"

namespace panelbass::models::diagnosis_detail {

/// Correlation of the estimation residual of `before` with what `after` adds to it.
double added_correlation(const Records& r, const Fit& before, const Fit& after);

/// One plain sentence: the physics candidate `c` adds and the evidence (`where`: the estimation residual's
/// location; `correlation`: added_correlation of the candidate).
std::string explain(const Candidate& c, const ResidualLocation& where, double correlation);

/// The gray-box terms of `m` as JSON: effect, state, threshold, time constant, sidedness, coefficients.
nlohmann::json terms_json(const AugmentedModel& m);

}  // namespace panelbass::models::diagnosis_detail

#pragma once
// Diagnosis, the linear refits' candidates: a sample more or less of dead time, and a pole and zero pair at the
// residual's spectral peak (resonance or antiresonance). Folder-internal (namespace diagnosis_detail), offered
// by candidates() (diagnosis_candidates.cpp).

#include <functional>

#include "models/diagnosis/diagnosis_fit.h"

namespace panelbass::models::diagnosis_detail {

/// The linear refits of `current`'s linear part offered to `offer`, each judged against the same structure
/// refitted on the same record (what a refit gains by itself is credited to no effect): the delay one sample
/// more or less, and a pole and zero pair seeded at `where`'s spectral peak (`oe_iterations` per OE refit).
void linear_refit_candidates(const Records& r, const Fit& current, const ResidualLocation& where, int oe_iterations,
                             const std::function<void(Candidate)>& offer);

}  // namespace panelbass::models::diagnosis_detail

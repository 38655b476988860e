#pragma once
// Diagnosis, the linear refits' candidates: a sample more or less of dead time, and a pole and zero pair at the
// residual's spectral peak or FRF error (resonance or antiresonance). Folder-internal (namespace
// diagnosis_detail), offered by candidates() (diagnosis_candidates.cpp).

#include <functional>

#include "models/diagnosis/diagnosis_fit.h"

namespace panelbass::models::diagnosis_detail {

/// The linear refits of `current`'s linear part offered to `offer`: the delay one sample more or less (offered
/// only when it beats the same structure refitted on the same record), and a pole and zero pair seeded at
/// `where`'s spectral peak and FRF error (`oe_iterations` per OE refit); each carries that same-structure
/// refit's J (`J_val_same_structure_refit_pct`): a pair's gain over it is the pair's own.
void linear_refit_candidates(const Records& r, const Fit& current, const ResidualLocation& where, int oe_iterations,
                             const std::function<void(Candidate)>& offer);

}  // namespace panelbass::models::diagnosis_detail

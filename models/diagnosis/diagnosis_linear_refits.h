#pragma once
// Diagnosis, the linear refits' candidates: a sample more or less of dead time, and a pole and zero pair at the
// residual's spectral peak or FRF error (resonance or antiresonance). Folder-internal (namespace
// diagnosis_detail), offered by candidates() (diagnosis_candidates.cpp).

#include <functional>
#include <string>

#include "models/diagnosis/diagnosis_fit.h"

namespace panelbass::models::diagnosis_detail {

/// The linear refits of `current`'s linear part offered to `offer`: the delay one sample more or less (offered
/// only when it beats the same structure refitted on the same record), and a pole and zero pair seeded at
/// `where`'s spectral peak and FRF error (`oe_iterations` per OE refit); each carries that same-structure
/// refit's J (`J_val_same_structure_refit_pct`): a pair's gain over it is the pair's own.
/// Why a resonance or antiresonance candidate `c` is no extra mode: its pair changes the response inside the
/// half-power band of a lightly damped resonance the baseline already has (it retunes that one). Empty when it
/// may be one, or when `c` is of another effect.
std::string ruled_out_as_extra_mode(const Candidate& c);

void linear_refit_candidates(const Records& r, const Fit& current, const ResidualLocation& where, int oe_iterations,
                             const std::function<void(Candidate)>& offer);

}  // namespace panelbass::models::diagnosis_detail

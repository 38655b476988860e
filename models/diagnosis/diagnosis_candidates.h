#pragma once
// Diagnosis, step two: the candidate augmentations of a model — each effect's gray-box term (or a linear
// refit: a delay, a pole and zero pair) fitted on the estimation record and judged on the validation record.
// Folder-internal (namespace diagnosis_detail): the driver (diagnosis.cpp) and the explanations use it.
// The kinds live in their own files: the fit (diagnosis_fit.h), the static nonlinearity's block structures
// (diagnosis_static_nonlinearity.h), the linear refits (diagnosis_linear_refits.h), the periodic records'
// parity rule (diagnosis_parity.h); the gray-box terms of the physics are here.

#include "models/diagnosis/diagnosis_fit.h"
#include "models/diagnosis/diagnosis_parity.h"

namespace panelbass::models::diagnosis_detail {

/// Every candidate augmentation of `current`, fitted; the best variant of each effect (by its BIC score
/// against `current`) is kept. `where` is the estimation residual's location (its spectral peak seeds the
/// pole and zero pair). `tried`, when given, is set to how many variants were fitted (the count a test over the
/// round's candidates corrects for).
std::vector<Candidate> candidates(const Records& r, const Fit& current, const ResidualLocation& where,
                                  int oe_iterations, int* tried = nullptr);

/// `current` with every gray-box term of the vocabulary it lacks fitted at once (each state the output's quantity
/// allows, one time constant of creep and of thermal compression): what no candidate term explains is what it
/// leaves on the validation record.
Fit every_term_at_once(const Records& r, const Fit& current);

}  // namespace panelbass::models::diagnosis_detail

#pragma once
// Diagnosis, the static nonlinearity's candidates: where it sits in a block structure and its shape.
// Folder-internal (namespace diagnosis_detail), offered by candidates() (diagnosis_candidates.cpp).

#include <functional>

#include "models/diagnosis/diagnosis_fit.h"

namespace panelbass::models::diagnosis_detail {

/// The static nonlinearity's candidates, offered to `offer`: the baseline's dynamics split around it
/// (Wiener: all before; Wiener–Hammerstein: some pole groups before, the rest with the zeros after), the best
/// split found with one shape, then its shapes (a knee on both sides or each on its own at five levels, a
/// polynomial of order 3); each with its position, structure and shape (saturating, dead zone, polynomial).
void static_nonlinearity_candidates(const Records& r, const Fit& current, const std::function<void(Candidate)>& offer);

}  // namespace panelbass::models::diagnosis_detail

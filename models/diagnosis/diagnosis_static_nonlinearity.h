#pragma once
// Diagnosis, the static nonlinearity's candidates: where it sits in a block structure and its shape (at the drive
// end it is the amplifier's saturation).
// Folder-internal (namespace diagnosis_detail), offered by candidates() (diagnosis_candidates.cpp).

#include <functional>

#include "models/diagnosis/diagnosis_fit.h"

namespace panelbass::models::diagnosis_detail {

/// Whether a static function with `front` before it sits at the drive end of `dynamics` (rate `fs`): nothing
/// before it, or only a filter of the drive — real poles and well-damped pairs (damping ratio ≥ kLightDamping),
/// each above the lowest resonance of `dynamics` — so that every resonance of the mechanics comes after it.
/// False when `dynamics` has no resonance (nothing then tells the drive's filter from the rest).
bool at_drive_end(const TransferFunction& front, const TransferFunction& dynamics, double fs);

/// The candidates of a static function of the drive placed in the baseline's block structure, offered to `offer`.
/// At the drive end (at_drive_end: the drive as sampled, or behind the drive's filter) it is `saturation`, the
/// amplifier clipping: the best placement found with one shape, then a knee on both sides or each on its own at
/// eleven levels. Elsewhere it is `static_nonlinearity`: the baseline's dynamics split around it (Wiener: all
/// before; Wiener–Hammerstein: some pole groups before, the rest with the zeros after), the best split found with
/// one shape, then its shapes (a knee on both sides or each on its own at five levels, a polynomial of order 3).
/// Each carries its position, structure, the pole groups before and after it, and its shape (saturating, dead
/// zone, polynomial).
void static_nonlinearity_candidates(const Records& r, const Fit& current, const std::function<void(Candidate)>& offer);

}  // namespace panelbass::models::diagnosis_detail

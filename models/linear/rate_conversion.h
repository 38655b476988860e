#pragma once
// Linear models moved between sample rates by pole mapping (thesis appendix 2).

#include "models/linear/transfer_function.h"

namespace panelbass::models {

/// The same dynamics at another sample rate (thesis appendix 2): each mode of the partial-fraction
/// expansion keeps its continuous-time decay and frequency (λ → λ^(fs_from/fs_to)), its residue scaled
/// by fs_from/fs_to (impulse invariance), the direct term kept. Throws std::invalid_argument for a pole
/// on the negative real axis (no continuous-time equivalent) or repeated poles.
TransferFunction convert_rate(const TransferFunction& tf, double fs_from, double fs_to);

}  // namespace panelbass::models

#pragma once
// Diagnosis, periodic data weigh in: which harmonics a candidate's term makes, and whether a periodic record's
// residual rules it out. Folder-internal (namespace diagnosis_detail), used by the driver (diagnosis.cpp).

#include <string>

#include "models/diagnosis/diagnosis_fit.h"

namespace panelbass::models::diagnosis_detail {

/// Which harmonics an effect's term makes from a multisine: odd, even, both, or none (a linear refit or
/// a constant).
enum class DistortionParity { none, odd, even, both };

/// The parity of the distortion candidate `c` adds (its effect, and for saturation its sidedness).
DistortionParity distortion_parity(const Candidate& c);

/// Whether `c` can be what a periodic record's residual misses: with an odd multisine, a residual that
/// shows distortion at the empty lines of one parity but not the other rules out a term that makes only the
/// other. Empty when it can; otherwise why not, in words.
std::string ruled_out_by_periodic_distortion(const Candidate& c, const PeriodicDistortion& residual);

}  // namespace panelbass::models::diagnosis_detail

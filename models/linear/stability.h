#pragma once
// The one stability check of a linear model: its loader and the API's validation both ask it.

#include <optional>

#include "models/linear/transfer_function.h"

namespace panelbass::models {

/// A pole on or outside the unit circle.
struct UnstablePole {
  double radius = 0.0;  ///< |z|
  double hz = 0.0;      ///< its frequency |arg z|·fs/2π (NaN when fs is)
};

/// The pole of `tf` farthest from the origin when it is not strictly inside the unit circle; nullopt
/// when `tf` is stable (an FIR always is).
std::optional<UnstablePole> unstable_pole(const TransferFunction& tf, double fs);

}  // namespace panelbass::models

#pragma once
// The range checks a use case's check(request) makes, each a RequestError naming the field in the same words.

#include <string>

#include "models/io/number_text.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {

/// Throws RequestError(field, "must be within lo..hi, got v") for v outside [lo, hi].
inline void within(const std::string& field, long long v, long long lo, long long hi) {
  if (v < lo || v > hi) {
    throw RequestError(field, "must be within " + std::to_string(lo) + ".." + std::to_string(hi) + ", got " + std::to_string(v));
  }
}

/// Throws RequestError(field, "must be within [lo, hi], got v") for a number outside [lo, hi] (or not a number).
inline void within_real(const std::string& field, double v, double lo, double hi) {
  if (!(v >= lo && v <= hi)) {
    throw RequestError(field, "must be within [" + models::number_text(lo) + ", " + models::number_text(hi) + "], got " +
                                  models::number_text(v));
  }
}

}  // namespace panelbass::usecases

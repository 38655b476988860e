#pragma once
// Errors of estimators: data that cannot support the model asked for, or a fit that failed.

#include <stdexcept>

namespace panelbass::models {

/// An estimation that cannot be done or did not succeed; the message says why in the user's terms
/// ("ARX(8,8): 12 samples are too few for 16 parameters", "OE: the input is constant").
class EstimationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace panelbass::models

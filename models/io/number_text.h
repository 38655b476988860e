#pragma once
// The one way a number is written into an error message or a report line.

#include <complex>
#include <string>

namespace panelbass::models {

/// `v` as text with `significant` significant digits (std::ostream's general format: 0.0365, 1e-05).
std::string number_text(double v, int significant = 6);

/// `z` as "re + imj" (or "re − imj"), each part with `significant` significant digits.
std::string number_text(std::complex<double> z, int significant = 6);

}  // namespace panelbass::models

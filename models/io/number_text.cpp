#include "models/io/number_text.h"

#include <cmath>
#include <sstream>

namespace panelbass::models {

std::string number_text(double v, int significant) {
  std::ostringstream out;
  out.precision(significant);
  out << v;
  return out.str();
}

std::string number_text(std::complex<double> z, int significant) {
  std::ostringstream out;
  out.precision(significant);
  out << z.real() << (z.imag() < 0.0 ? " − " : " + ") << std::abs(z.imag()) << "j";
  return out.str();
}

}  // namespace panelbass::models

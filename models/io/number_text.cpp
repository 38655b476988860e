#include "models/io/number_text.h"

#include <sstream>

namespace panelbass::models {

std::string number_text(double v, int significant) {
  std::ostringstream out;
  out.precision(significant);
  out << v;
  return out.str();
}

}  // namespace panelbass::models

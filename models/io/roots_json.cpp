#include "models/io/roots_json.h"

namespace panelbass::models {

nlohmann::json roots_json(const Eigen::VectorXcd& roots) {
  nlohmann::json out = nlohmann::json::array();
  for (Eigen::Index k = 0; k < roots.size(); ++k) out.push_back({roots[k].real(), roots[k].imag()});
  return out;
}

}  // namespace panelbass::models

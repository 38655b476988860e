#include "models/preprocess/scaling.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "models/io/config_error.h"
#include "models/io/json_fields.h"

namespace panelbass::models {
namespace {

// Offset (mean) and scale (largest deviation from it) of one signal; `name` is "input" or "output".
void offset_and_scale(const Eigen::VectorXd& x, const char* name, double& offset, double& scale) {
  if (x.size() == 0) throw std::invalid_argument(std::string(name) + " is empty");
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    if (!std::isfinite(x[k])) {
      throw std::invalid_argument(std::string(name) + " is not finite (sample " + std::to_string(k) + ")");
    }
  }
  offset = x.mean();
  // The same expression as scale_u/scale_y, so the sample that sets the scale maps to exactly ±1 and
  // no other sample can round past it.
  scale = (x.array() - offset).abs().maxCoeff();
  if (!(scale > 0.0)) throw std::invalid_argument(std::string(name) + " is constant");
}

}  // namespace

Scaling scaling_from_data(const Eigen::VectorXd& u, const Eigen::VectorXd& y) {
  Scaling s;
  offset_and_scale(u, "input", s.u_offset, s.u_scale);
  offset_and_scale(y, "output", s.y_offset, s.y_scale);
  return s;
}

nlohmann::json scaling_to_json(const Scaling& s) {
  return {{"u_offset", s.u_offset}, {"u_scale", s.u_scale}, {"y_offset", s.y_offset}, {"y_scale", s.y_scale}};
}

Scaling scaling_from_json(const nlohmann::json& j, const std::string& path) {
  JsonFields f(j, path);
  Scaling s;
  s.u_offset = f.number("u_offset");
  s.u_scale = f.number("u_scale");
  require_positive(s.u_scale, f.path_of("u_scale"));
  s.y_offset = f.number("y_offset");
  s.y_scale = f.number("y_scale");
  require_positive(s.y_scale, f.path_of("y_scale"));
  f.finish();
  return s;
}

Scaling read_model_scaling(JsonFields& top) {
  const nlohmann::json* scaling = top.member("scaling");
  if (scaling == nullptr) throw ConfigError("model.scaling: missing");
  return scaling_from_json(*scaling, "model.scaling");
}

}  // namespace panelbass::models

#pragma once
// The thesis's scaling (ch. 3, figs 5.1/5.2): offsets removed and amplitudes scaled to |x| ≤ 1, stored
// in every model so that a model maps raw units to raw units.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>

#include "models/io/json_fields.h"

namespace panelbass::models {

/// scaled = (raw − offset) / scale, for the input and the output separately.
struct Scaling {
  double u_offset = 0.0, u_scale = 1.0;
  double y_offset = 0.0, y_scale = 1.0;

  /// The input in model units.
  Eigen::VectorXd scale_u(const Eigen::VectorXd& u) const { return (u.array() - u_offset) / u_scale; }
  /// The output in model units.
  Eigen::VectorXd scale_y(const Eigen::VectorXd& y) const { return (y.array() - y_offset) / y_scale; }
  /// A model output back in raw units.
  Eigen::VectorXd unscale_y(const Eigen::VectorXd& y) const { return y.array() * y_scale + y_offset; }
};

/// Offsets = means, scales = largest deviation from the mean, so both signals lie in [−1, 1] with zero
/// mean. Throws std::invalid_argument for a constant or non-finite signal (naming which).
Scaling scaling_from_data(const Eigen::VectorXd& u, const Eigen::VectorXd& y);

/// The scaling as JSON {"u_offset","u_scale","y_offset","y_scale"}.
nlohmann::json scaling_to_json(const Scaling& s);

/// Reads and validates a scaling (finite offsets, finite positive scales); ConfigError names the key.
Scaling scaling_from_json(const nlohmann::json& j, const std::string& path);

/// The required "scaling" of the model file behind `top`, read as scaling_from_json reads it; ConfigError
/// "model.scaling: missing" without one.
Scaling read_model_scaling(JsonFields& top);

}  // namespace panelbass::models

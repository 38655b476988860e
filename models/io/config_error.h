#pragma once
// Errors in configuration and model files.

#include <stdexcept>

namespace panelbass::models {

/// A configuration or model file that is malformed or non-physical; the message names the key path
/// ("plant.mechanical.mass_kg: must be > 0, got -1").
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace panelbass::models

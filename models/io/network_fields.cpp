#include "models/io/network_fields.h"

#include <cmath>
#include <string>

#include "models/io/config_error.h"

namespace panelbass::models {
namespace {

// Widths and depths beyond these are a corrupt file; they also keep P from overflowing.
constexpr long kMaxWidth = 100000;
constexpr std::size_t kMaxLayers = 100;

}  // namespace

std::vector<int> read_hidden(const nlohmann::json* v, const std::string& path) {
  if (v == nullptr) throw ConfigError(path + ": missing");
  if (!v->is_array()) throw ConfigError(path + ": expected an array of layer widths, got " + std::string(v->type_name()));
  if (v->empty()) throw ConfigError(path + ": must name at least one hidden layer");
  if (v->size() > kMaxLayers) {
    throw ConfigError(path + ": at most " + std::to_string(kMaxLayers) + " hidden layers, got " +
                      std::to_string(v->size()));
  }
  std::vector<int> hidden;
  for (std::size_t i = 0; i < v->size(); ++i) {
    const nlohmann::json& e = (*v)[i];
    const std::string where = path + "[" + std::to_string(i) + "]";
    if (!e.is_number_integer()) throw ConfigError(where + ": expected a positive integer, got " + std::string(e.type_name()));
    const long width = e.get<long>();
    if (width < 1 || width > kMaxWidth) {
      throw ConfigError(where + ": must be within [1, " + std::to_string(kMaxWidth) + "], got " + std::to_string(width));
    }
    hidden.push_back(static_cast<int>(width));
  }
  return hidden;
}

std::int64_t parameter_count(int inputs, const std::vector<int>& hidden) {
  std::int64_t count = 0;
  std::int64_t previous = inputs;
  for (int width : hidden) {
    count += (previous + 1) * width;
    previous = width;
  }
  return count + previous + 1;
}

Eigen::VectorXd read_theta(const nlohmann::json* v, const std::string& path, std::int64_t expected) {
  if (v == nullptr) throw ConfigError(path + ": missing");
  if (!v->is_array()) throw ConfigError(path + ": expected an array of numbers, got " + std::string(v->type_name()));
  if (static_cast<std::int64_t>(v->size()) != expected) {
    throw ConfigError(path + ": expected " + std::to_string(expected) + " weights for this structure, got " +
                      std::to_string(v->size()));
  }
  return read_vector(*v, path);
}

}  // namespace panelbass::models

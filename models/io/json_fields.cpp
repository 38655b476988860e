#include "models/io/json_fields.h"

#include <cmath>

#include "models/io/config_error.h"
#include "models/io/number_text.h"

namespace panelbass::models {
namespace {

std::string show(double v) { return number_text(v); }

}  // namespace

JsonFields::JsonFields(const nlohmann::json& value, std::string path) : value_(value), path_(std::move(path)) {
  if (!value_.is_object()) {
    throw ConfigError(path_ + ": expected an object, got " + std::string(value_.type_name()));
  }
}

std::string JsonFields::path_of(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

const nlohmann::json* JsonFields::member(const std::string& key) {
  known_.insert(key);
  auto it = value_.find(key);
  return it == value_.end() ? nullptr : &*it;
}

double JsonFields::number(const std::string& key) {
  const nlohmann::json* v = member(key);
  if (v == nullptr) throw ConfigError(path_of(key) + ": missing");
  if (!v->is_number()) {
    throw ConfigError(path_of(key) + ": expected a number, got " + std::string(v->type_name()));
  }
  const double d = v->get<double>();
  if (!std::isfinite(d)) throw ConfigError(path_of(key) + ": not finite");
  return d;
}

double JsonFields::number(const std::string& key, double fallback) {
  return value_.contains(key) ? number(key) : (known_.insert(key), fallback);
}

long JsonFields::integer(const std::string& key, long fallback, long lo, long hi) {
  const nlohmann::json* v = member(key);
  if (v == nullptr) return fallback;
  if (!v->is_number_integer()) {
    throw ConfigError(path_of(key) + ": expected an integer, got " + std::string(v->type_name()));
  }
  const long n = v->get<long>();
  if (n < lo || n > hi) {
    throw ConfigError(path_of(key) + ": must be within [" + std::to_string(lo) + ", " + std::to_string(hi) +
                      "], got " + std::to_string(n));
  }
  return n;
}

bool JsonFields::boolean(const std::string& key, bool fallback) {
  const nlohmann::json* v = member(key);
  if (v == nullptr) return fallback;
  if (!v->is_boolean()) {
    throw ConfigError(path_of(key) + ": expected true or false, got " + std::string(v->type_name()));
  }
  return v->get<bool>();
}

std::string JsonFields::string(const std::string& key, const std::string& fallback) {
  const nlohmann::json* v = member(key);
  if (v == nullptr) return fallback;
  if (!v->is_string()) {
    throw ConfigError(path_of(key) + ": expected a string, got " + std::string(v->type_name()));
  }
  return v->get<std::string>();
}

std::optional<std::string> JsonFields::unknown_key() const {
  for (auto it = value_.begin(); it != value_.end(); ++it) {
    if (!known_.contains(it.key())) return it.key();
  }
  return std::nullopt;
}

void JsonFields::finish() const {
  if (const std::optional<std::string> key = unknown_key()) throw ConfigError(path_of(*key) + ": unknown key");
}

void require_positive(double v, const std::string& path) {
  if (!(v > 0.0)) throw ConfigError(path + ": must be > 0, got " + show(v));
}

void require_non_negative(double v, const std::string& path) {
  if (!(v >= 0.0)) throw ConfigError(path + ": must be >= 0, got " + show(v));
}

void require_within(double v, double lo, double hi, const std::string& path) {
  if (!(v >= lo && v <= hi)) {
    throw ConfigError(path + ": must be within [" + show(lo) + ", " + show(hi) + "], got " + show(v));
  }
}

nlohmann::json number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

Eigen::VectorXd read_vector(const nlohmann::json& v, const std::string& path) {
  if (!v.is_array()) throw ConfigError(path + ": expected an array of numbers, got " + std::string(v.type_name()));
  Eigen::VectorXd x(static_cast<Eigen::Index>(v.size()));
  for (std::size_t i = 0; i < v.size(); ++i) {
    const std::string where = path + "[" + std::to_string(i) + "]";
    if (!v[i].is_number()) throw ConfigError(where + ": expected a number, got " + std::string(v[i].type_name()));
    const double d = v[i].get<double>();
    if (!std::isfinite(d)) throw ConfigError(where + ": not finite");
    x[static_cast<Eigen::Index>(i)] = d;
  }
  return x;
}

nlohmann::json to_array(const Eigen::VectorXd& x) {
  nlohmann::json a = nlohmann::json::array();
  for (Eigen::Index i = 0; i < x.size(); ++i) a.push_back(x[i]);
  return a;
}

Eigen::MatrixXd read_matrix(const nlohmann::json& v, const std::string& path, Eigen::Index rows, Eigen::Index cols) {
  if (!v.is_array()) throw ConfigError(path + ": expected an array of rows, got " + std::string(v.type_name()));
  if (static_cast<Eigen::Index>(v.size()) != rows) {
    throw ConfigError(path + ": expected " + std::to_string(rows) + " rows, got " + std::to_string(v.size()));
  }
  Eigen::MatrixXd x(rows, cols);
  for (Eigen::Index i = 0; i < rows; ++i) {
    const std::string where = path + "[" + std::to_string(i) + "]";
    const Eigen::VectorXd row = read_vector(v[static_cast<std::size_t>(i)], where);
    if (row.size() != cols) {
      throw ConfigError(where + ": expected " + std::to_string(cols) + " numbers, got " + std::to_string(row.size()));
    }
    x.row(i) = row.transpose();
  }
  return x;
}

nlohmann::json to_rows(const Eigen::MatrixXd& x) {
  nlohmann::json a = nlohmann::json::array();
  for (Eigen::Index i = 0; i < x.rows(); ++i) a.push_back(to_array(x.row(i).transpose()));
  return a;
}

}  // namespace panelbass::models

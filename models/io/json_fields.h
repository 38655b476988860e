#pragma once
// Validated reading of one JSON object: typed fields, defaults, key paths in every error, and no
// unknown keys let through; and the one rule for writing a number that may not be finite.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>

namespace panelbass::models {

/// Reads the fields of one JSON object at `path` ("plant.mechanical"). Every accessor names the full
/// key path in its ConfigError; finish() rejects any key that no accessor asked for.
class JsonFields {
 public:
  /// Wraps `value`, which must be an object (else ConfigError naming `path`).
  JsonFields(const nlohmann::json& value, std::string path);

  /// A finite number; `fallback` when the key is absent.
  double number(const std::string& key, double fallback);
  /// A finite number that must be present.
  double number(const std::string& key);
  /// An integer in [lo, hi]; `fallback` when absent.
  long integer(const std::string& key, long fallback, long lo, long hi);
  /// A boolean; `fallback` when absent.
  bool boolean(const std::string& key, bool fallback);
  /// A string; `fallback` when absent.
  std::string string(const std::string& key, const std::string& fallback);
  /// The raw member, or nullptr when absent (marks the key as known).
  const nlohmann::json* member(const std::string& key);

  /// Full path of `key` inside this object, for messages.
  std::string path_of(const std::string& key) const;

  /// The first key (in the object's order) that no accessor asked for; nullopt when there is none.
  std::optional<std::string> unknown_key() const;

  /// Throws ConfigError naming the first key that was never asked for.
  void finish() const;

 private:
  const nlohmann::json& value_;
  std::string path_;
  std::set<std::string> known_;
};

/// Throws ConfigError "`path`: must be > 0, got v" unless v > 0.
void require_positive(double v, const std::string& path);
/// Throws ConfigError "`path`: must be >= 0, got v" unless v >= 0.
void require_non_negative(double v, const std::string& path);
/// Throws ConfigError "`path`: must be within [lo, hi], got v" unless lo <= v <= hi.
void require_within(double v, double lo, double hi, const std::string& path);

/// `v` as a JSON number, or null where it is not finite (NaN, ±inf: JSON has no such numbers).
nlohmann::json number_or_null(double v);

/// A JSON array of finite numbers as a vector; ConfigError names the element ("model.params.a[3]: not finite").
Eigen::VectorXd read_vector(const nlohmann::json& v, const std::string& path);

/// The entries of `x` as a JSON array of numbers.
nlohmann::json to_array(const Eigen::VectorXd& x);

/// A JSON array of `rows` rows, each an array of `cols` finite numbers, as a matrix; ConfigError names the
/// element or the row whose length is wrong ("model.params.B[2]: expected 3 numbers, got 2").
Eigen::MatrixXd read_matrix(const nlohmann::json& v, const std::string& path, Eigen::Index rows, Eigen::Index cols);

/// The rows of `x` as a JSON array of arrays of numbers.
nlohmann::json to_rows(const Eigen::MatrixXd& x);

}  // namespace panelbass::models

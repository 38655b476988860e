#pragma once
// Checking a job's params (ROUTES.md "Jobs") before it is queued: a reader that takes one JSON object
// field by field (typed, ranged, defaults filled in, unknown fields refused, every error naming
// "params.<field>"), the checks of each kind, and the excitation record an excite job leaves behind.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "api/job_kinds.h"

namespace panelbass::api {

/// A range of real numbers with open or closed ends, e.g. (0, 1].
struct Interval {
  double lo = 0.0;
  double hi = 0.0;
  bool lo_open = false;
  bool hi_open = false;

  /// True when `v` lies in the interval.
  bool contains(double v) const;
  /// "(0, 1]", "[0, inf)", …
  std::string text() const;
};

/// Reads one params object: each accessor marks its key as known, checks the value (throwing
/// std::invalid_argument "<path>.<key>: …") and records it, with the default when absent, in the
/// filled-in params that finish() returns.
class ParamReader {
 public:
  /// Wraps `params` (an object; null counts as {}) found at `path` ("params", "params.excite").
  ParamReader(const nlohmann::json& params, std::string path);

  /// An integer within [lo, hi]; `fallback` when absent.
  long long integer(const std::string& key, long long fallback, long long lo, long long hi);
  /// A finite number within `range`; `fallback` when absent.
  double number(const std::string& key, double fallback, const Interval& range);
  /// true or false; `fallback` when absent.
  bool boolean(const std::string& key, bool fallback);
  /// One of `choices`; `fallback` when absent.
  std::string choice(const std::string& key, const std::string& fallback, const std::vector<std::string>& choices);
  /// A list of `min_count`..`max_count` integers, each within [lo, hi]; `fallback` when absent.
  std::vector<long long> integers(const std::string& key, const std::vector<long long>& fallback, std::size_t min_count,
                                  std::size_t max_count, long long lo, long long hi);
  /// A list of `min_count`..`max_count` finite numbers, each within `range`; `fallback` when absent.
  std::vector<double> numbers(const std::string& key, const std::vector<double>& fallback, std::size_t min_count,
                              std::size_t max_count, const Interval& range);
  /// A non-empty list of entries of `choices`; `fallback` when absent.
  std::vector<std::string> choices(const std::string& key, const std::vector<std::string>& fallback,
                                   const std::vector<std::string>& choices);
  /// An id (is_valid_id); nullopt when absent and not `required`.
  std::optional<std::string> id(const std::string& key, bool required);
  /// The raw member, or nullptr when absent (the key counts as known; nothing is recorded).
  const nlohmann::json* member(const std::string& key);
  /// Records `value` under `key` in the filled-in params (the key counts as known).
  void set(const std::string& key, nlohmann::json value);

  /// "<path>.<key>".
  std::string path_of(const std::string& key) const;
  /// Throws for the first field no accessor asked for ("<path>.foo: unknown field"); returns the params
  /// with every default filled in.
  nlohmann::json finish() const;

 private:
  const nlohmann::json* find(const std::string& key);

  nlohmann::json params_;
  std::string path_;
  std::vector<std::string> known_;
  nlohmann::json filled_ = nlohmann::json::object();
};

/// The estimation and validation parts of a recording: raw drive u and response y.
struct ExcitationRecord {
  Eigen::VectorXd u_est, y_est, u_val, y_val;
  Eigen::VectorXd w_est, w_val;  ///< per-sample harmonic weights of a control excitation; empty otherwise
};

/// {"u_est":[…],"y_est":[…],"u_val":[…],"y_val":[…]}, and "w_est", "w_val" when the record has weights.
nlohmann::json excitation_record_to_json(const ExcitationRecord& record);

/// The record in an excite job's result ({"fs", "record":{…}}), checked: four arrays of finite numbers,
/// equal lengths per part, at least 200 estimation samples, recorded at `fs`. Throws std::invalid_argument
/// starting with `where` ("params.record: job j3 …").
ExcitationRecord excitation_record_from_result(const nlohmann::json& result, double fs, const std::string& where);

/// The fewest samples a record part must have.
inline constexpr long long kMinSamples = 200;
/// The most samples a record part may have.
inline constexpr long long kMaxSamples = 10'000'000;

/// The params of `kind` checked against `env`, defaults filled in; the checks of validate_job_params()
/// without the check of the kind's name. Throws std::invalid_argument naming the field.
nlohmann::json validate_kind_params(const std::string& kind, const nlohmann::json& params, const JobEnvironment& env);

}  // namespace panelbass::api

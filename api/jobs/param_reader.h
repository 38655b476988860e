#pragma once
// Reading a job's params (ROUTES.md "Jobs") before it is queued: one JSON object field by field — typed,
// ranged, defaults filled in, unknown fields refused, every error naming "params.<field>" — on the models'
// validated reader (models::JsonFields), which keeps the key paths and the fields asked for.

#include <nlohmann/json.hpp>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "models/io/json_fields.h"
#include "usecases/request_error.h"

namespace panelbass::api {

/// Seeds are integers a JSON client can hold exactly (2^53).
inline constexpr long long kMaxSeed = 9'007'199'254'740'992LL;
/// Highest model order, numerator length or network lag a job accepts (FIR taps may go further).
inline constexpr long long kMaxOrder = 40;
/// Iterations of any training loop.
inline constexpr long long kMaxIterations = 10'000;

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

/// Any finite number: for a field whose range a use case's check says (the same words at both doors).
inline constexpr Interval kAnyFinite{-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(), true, true};

/// Any int: for an integer field whose range a use case's check says (the same words at both doors).
inline constexpr long long kAnyInteger = std::numeric_limits<int>::max();

/// Reads one params object: each accessor marks its key as known, checks the value (throwing
/// std::invalid_argument "<path>.<key>: …") and records it, with the default when absent, in the
/// filled-in params that finish() returns.
class ParamReader {
 public:
  /// Wraps `params` (an object; null counts as {}) found at `path` ("params", "params.excite").
  ParamReader(const nlohmann::json& params, std::string path);
  ParamReader(const ParamReader&) = delete;
  ParamReader& operator=(const ParamReader&) = delete;

  /// An integer within [lo, hi]; `fallback` when absent.
  long long integer(const std::string& key, long long fallback, long long lo, long long hi);
  /// A finite number within `range`; `fallback` when absent.
  double number(const std::string& key, double fallback, const Interval& range);
  /// true or false; `fallback` when absent.
  bool boolean(const std::string& key, bool fallback);
  /// Any string (a use case's check says which values it takes); `fallback` when absent or null.
  std::string text(const std::string& key, const std::string& fallback);
  /// One of `choices`; `fallback` when absent.
  std::string choice(const std::string& key, const std::string& fallback, const std::vector<std::string>& choices);
  /// Any list of strings (a use case's check says which it takes); `fallback` when absent or null.
  std::vector<std::string> texts(const std::string& key, const std::vector<std::string>& fallback);
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
  const nlohmann::json params_;
  models::JsonFields fields_;  ///< over params_: the key paths and the keys asked for
  nlohmann::json filled_ = nlohmann::json::object();
};

/// Throws std::invalid_argument "<path>: <what>".
[[noreturn]] void refuse(const std::string& path, const std::string& what);

/// Runs `check` (a use case's request check, or the use case itself) and turns a RequestError it throws into
/// std::invalid_argument "params.<field>: <problem>", as the API names a field.
template <typename Check>
void check_request(Check&& check) {
  try {
    check();
  } catch (const usecases::RequestError& e) {
    refuse("params." + e.field(), e.problem());
  }
}

/// A short rendering of a value for a message: `"x"`, `12.5`, `[1,2]` (long ones cut).
std::string shown(const nlohmann::json& value);

}  // namespace panelbass::api

#pragma once
// Parsing JSON that comes from outside (a request body, an uploaded model, a file in the store) with the
// limits a hostile text could otherwise break: nesting depth checked while parsing, before anything deeper is
// built, and a key given twice in one object refused instead of the last one silently winning.

#include <cstddef>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string_view>

namespace panelbass::models {

/// The deepest nesting a JSON text from outside may have unless a caller says otherwise (every model file and
/// request of panelbass nests a handful of levels).
inline constexpr std::size_t kMaxJsonDepth = 64;

/// A JSON text that breaks a limit of parse_bounded_json: the message says what and where (the key path).
class JsonLimitError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// Parses `text` as nlohmann::json::parse does (its parse_error and out_of_range for malformed text and numbers
/// beyond a double), but throws JsonLimitError for nesting deeper than `max_depth` (counted while parsing) and
/// for a key repeated within one object, naming the key and its path ("duplicate key \"kind\" at the top level").
nlohmann::json parse_bounded_json(std::string_view text, std::size_t max_depth = kMaxJsonDepth);

}  // namespace panelbass::models

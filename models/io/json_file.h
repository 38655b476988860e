#pragma once
// Reading JSON files with errors that name the file.

#include <filesystem>
#include <nlohmann/json.hpp>

#include "models/io/config_error.h"

namespace panelbass::models {

/// Parses the JSON file at `path` with the API's limits (models::parse_bounded_json: nesting at most
/// kMaxJsonDepth levels, counted while parsing; no key twice in one object); ConfigError "<path>: cannot open …",
/// "<path>: is a directory", "<path>: not valid JSON: …", "<path>: not acceptable JSON: …" (a limit broken).
nlohmann::json read_json_file(const std::filesystem::path& path);

/// Reads the JSON file at `path` through `from_json` (a kind's validating reader); its ConfigError is
/// prefixed with the file name, "<path>: …".
template <class FromJson>
auto read_json_file_as(const std::filesystem::path& path, FromJson from_json) {
  const nlohmann::json json = read_json_file(path);
  try {
    return from_json(json);
  } catch (const ConfigError& e) {
    throw ConfigError(path.string() + ": " + e.what());
  }
}

/// Writes `value` (indented) to `path` through a temporary file and a rename, so a reader never sees a
/// half-written file; ConfigError naming the path if it cannot.
void write_json_file(const std::filesystem::path& path, const nlohmann::json& value);

}  // namespace panelbass::models

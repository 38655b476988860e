#pragma once
// Reading JSON files with errors that name the file.

#include <filesystem>
#include <nlohmann/json.hpp>

namespace panelbass::models {

/// Parses the JSON file at `path`; ConfigError "<path>: cannot open …", "<path>: is a directory",
/// "<path>: not valid JSON: …".
nlohmann::json read_json_file(const std::filesystem::path& path);

/// Writes `value` (indented) to `path` through a temporary file and a rename, so a reader never sees a
/// half-written file; ConfigError naming the path if it cannot.
void write_json_file(const std::filesystem::path& path, const nlohmann::json& value);

}  // namespace panelbass::models

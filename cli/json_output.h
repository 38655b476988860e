#pragma once
// The CLI contract: one JSON object on stdout per command.

#include <nlohmann/json.hpp>

namespace panelbass::cli {

/// Prints `result` on stdout, indented, followed by a newline.
void print_result(const nlohmann::json& result);

}  // namespace panelbass::cli

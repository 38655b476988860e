#pragma once
// Checks on a message or a report's text.

#include <string>

namespace panelbass::testing_support {

/// Whether `text` contains `part`.
inline bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace panelbass::testing_support

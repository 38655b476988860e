#pragma once
// What an action throws: its error message, checked to be one line or taken as it is.

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace panelbass::testing_support {

/// The message of the `Error` that `action` throws (a test failure if it throws none); it must be one line.
template <class Error, class Action>
std::string one_line_error(Action action) {
  try {
    action();
  } catch (const Error& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.find('\n'), std::string::npos) << "message is not one line: " << message;
    return message;
  }
  const std::string type = ::testing::internal::GetTypeName<Error>();
  ADD_FAILURE() << "no " << type.substr(type.rfind(':') + 1) << " was thrown";
  return {};
}

/// The message of the `Error` that `action` throws, or `none` if it throws nothing.
template <class Error, class Action>
std::string message_of(Action action, const std::string& none = "") {
  try {
    action();
  } catch (const Error& error) {
    return error.what();
  }
  return none;
}

/// Expects `action` to throw std::invalid_argument whose message names `parameter`.
template <class Action>
void expect_invalid(Action&& action, const std::string& parameter) {
  try {
    action();
    ADD_FAILURE() << "no exception; expected one naming " << parameter;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(parameter), std::string::npos) << e.what();
  }
}

}  // namespace panelbass::testing_support

#pragma once
// Errors in data that came from outside: files, columns, channels, values.

#include <stdexcept>
#include <string>

namespace panelbass::dsp {

/// A problem with input data; the message names the file and the place in it
/// ("run.csv:1204: column \"y\": not a number: \"abc\"").
class DataError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace panelbass::dsp

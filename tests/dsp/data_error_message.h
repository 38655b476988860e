#pragma once
// The message of the DataError a data-file action throws: the dsp tests' check of a bad file's error.

#include <string>

#include "dsp/data_error.h"
#include "tests/support/expect_error.h"

namespace panelbass::dsp::testing {

/// The message of the DataError that `action` throws (a failure if it throws none); it must be one line.
template <class Action>
std::string data_error(Action action) {
  return testing_support::one_line_error<DataError>(action);
}

}  // namespace panelbass::dsp::testing

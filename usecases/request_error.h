#pragma once
// A request a use case refuses: which field, and what is wrong with it. Each door spells the field its own way
// (the API "params.max_input", the CLI "--max-input") in front of the same words.

#include <stdexcept>
#include <string>

namespace panelbass::usecases {

/// A request field out of range or inconsistent with another: `field` as the request struct names it
/// ("max_input", "band_pass.high_hz"), `problem` the words after it.
class RequestError : public std::invalid_argument {
 public:
  /// what() is "<field>: <problem>".
  RequestError(std::string field, std::string problem)
      : std::invalid_argument(field + ": " + problem), field_(std::move(field)), problem_(std::move(problem)) {}
  /// The field, as the request struct names it.
  const std::string& field() const { return field_; }
  /// What is wrong, without the field.
  const std::string& problem() const { return problem_; }

 private:
  std::string field_, problem_;
};

}  // namespace panelbass::usecases

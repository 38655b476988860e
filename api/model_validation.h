#pragma once
// What a model file must satisfy before the store keeps it or the engine runs it: the model-kind registry's
// checks (models/kinds/model_file.h), worded as the API answers them.

#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

namespace panelbass::api {

/// Kind and rate of a model that passed validation.
struct ValidatedModel {
  std::string kind;  ///< a kind of the registry ("linear", "mirror_filter", …)
  double fs = 0.0;   ///< Hz
};

/// Why a model was refused: `code` "bad_request" (not a model file: format, kind, fields, dimensions) or
/// "invalid_model" (it parses but has non-finite numbers or is unstable); the message names the key path.
class ModelRejected : public std::runtime_error {
 public:
  /// `code` as above.
  ModelRejected(std::string code, const std::string& message) : std::runtime_error(message), code_(std::move(code)) {}
  /// "bad_request" or "invalid_model".
  const std::string& code() const { return code_; }

 private:
  std::string code_;
};

/// Validates a model file object of any kind of the registry with the kind's own checks (format, fields,
/// dimensions; every number finite, the first non-finite one named by its key path; stability: poles inside the
/// unit circle, a bounded free run or closed loop, a finite mirror filter on full-scale noise). Throws
/// ModelRejected.
ValidatedModel validate_model(const nlohmann::json& model);

}  // namespace panelbass::api

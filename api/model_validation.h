#pragma once
// What a model file must satisfy before the store keeps it or the engine runs it.

#include <nlohmann/json.hpp>
#include <string>

namespace panelbass::api {

/// Kind and rate of a model that passed validation.
struct ValidatedModel {
  std::string kind;  ///< "linear", "narx", "lq_feedforward", "neural_feedback"
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

/// Validates a model file object of any kind the engine runs: the kind's own loader (format, fields,
/// dimensions), every number finite (the first non-finite one named by its key path), stability (a linear
/// or LQ model's poles — its A matrix's spectral radius — inside the unit circle; a NARX model, also the
/// one inside neural_feedback, run free for 2000 samples on uniform noise spanning its scaled input range
/// must stay finite and within 100× its output scaling range). Throws ModelRejected.
ValidatedModel validate_model(const nlohmann::json& model);

}  // namespace panelbass::api

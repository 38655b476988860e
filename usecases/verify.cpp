#include "usecases/verify.h"

#include <stdexcept>

#include "models/control/lq_feedforward.h"
#include "models/kinds/model_file.h"
#include "usecases/band_pass.h"
#include "usecases/request_error.h"

namespace panelbass::usecases {
namespace {

// Refuses `file` under `field` unless it is a model of a kind that takes `role`.
void require_slot(const nlohmann::json& file, const std::string& field, models::ModelRole role) {
  try {
    models::require_role(models::model_kind_of(file), role, field);
  } catch (const std::exception& e) {
    const std::string what = e.what();
    const std::string prefix = field + ": ";
    throw RequestError(field, what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what);
  }
}

}  // namespace

void check(const VerifyRequest& q) {
  if (q.feedforward_name.empty()) throw RequestError("feedforward_model", "required");
  if (!(q.safe_level > 0.0 && q.safe_level <= 1.0)) throw RequestError("safe_level", "must be within (0, 1]");
  check(q.settings, q.chain.fs);
}

nlohmann::json to_json(const VerifyRequest& q) {
  nlohmann::json fields = to_json(q.settings);
  fields["feedforward_model"] = q.feedforward_name;
  fields["feedback_model"] = q.feedback_name.empty() ? nlohmann::json(nullptr) : nlohmann::json(q.feedback_name);
  return fields;
}

engine::ChainConfig verified_chain(const VerifyRequest& q) {
  require_slot(q.feedforward_model, "feedforward_model", models::ModelRole::feedforward);
  engine::ChainConfig chain = q.chain;
  if (q.feedforward_model.value("kind", "") == "lq_feedforward") {
    BandPass band;
    try {
      band = band_pass_of(models::lq_feedforward_from_json(q.feedforward_model));
    } catch (const std::exception& e) {
      throw RequestError("feedforward_model", e.what());
    }
    chain.band_pass.design.low = engine::Hertz{band.low_hz};
    chain.band_pass.design.high = engine::Hertz{band.high_hz};
    chain.band_pass.design.order = band.order;
  }
  chain.band_pass.bypass = false;
  chain.feedforward = engine::SlotConfig{};
  chain.feedforward->model = q.feedforward_model;
  chain.feedback.reset();
  if (!q.feedback_name.empty()) {
    require_slot(q.feedback_model, "feedback_model", models::ModelRole::feedback);
    chain.feedback = engine::SlotConfig{};
    chain.feedback->model = q.feedback_model;
    chain.feedback->source = engine::FeedbackSource::model;
  }
  return chain;
}

EqualOutputReport verify(const VerifyRequest& q, const PlayFunction& play, Progress& progress) {
  check(q);
  EqualOutputRequest v;
  v.chain = verified_chain(q);
  v.safe_level = q.safe_level;
  v.settings = q.settings;
  return verify_equal_output(v, play, progress);
}

}  // namespace panelbass::usecases

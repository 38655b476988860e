#include "models/io/model_header.h"

#include "models/io/config_error.h"

namespace panelbass::models {

double read_model_header(JsonFields& top, const std::string& kind) {
  if (top.member("format") == nullptr) throw ConfigError("model.format: missing");
  const std::string format = top.string("format", "");
  if (format != kModelFormat) {
    throw ConfigError("model.format: expected \"" + std::string(kModelFormat) + "\", got \"" + format + "\"");
  }
  if (top.member("kind") == nullptr) throw ConfigError("model.kind: missing");
  const std::string found = top.string("kind", "");
  if (found != kind) throw ConfigError("model.kind: expected \"" + kind + "\", got \"" + found + "\"");
  const double fs = top.number("fs");
  require_positive(fs, "model.fs");
  return fs;
}

nlohmann::json read_model_meta(JsonFields& top) {
  const nlohmann::json* meta = top.member("meta");
  if (meta == nullptr) return nlohmann::json::object();
  if (!meta->is_object()) throw ConfigError("model.meta: expected an object, got " + std::string(meta->type_name()));
  return *meta;
}

const nlohmann::json& read_model_params(JsonFields& top) {
  const nlohmann::json* params = top.member("params");
  if (params == nullptr) throw ConfigError("model.params: missing");
  return *params;
}

}  // namespace panelbass::models

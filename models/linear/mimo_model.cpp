#include "models/linear/mimo_model.h"

#include <set>

#include "models/io/config_error.h"
#include "models/io/json_fields.h"
#include "models/io/json_file.h"
#include "models/io/model_header.h"
#include "models/io/number_text.h"

namespace panelbass::models {
namespace {

constexpr const char* kMimoKind = "mimo";
constexpr long kMaxMimoOrder = 1000;     // states: beyond this a file is corrupt, not a model
constexpr long kMaxMimoChannels = 1000;  // inputs or outputs

/// Channel names at `path`: a non-empty array of unique non-empty strings.
std::vector<std::string> read_channel_names(const nlohmann::json* v, const std::string& path) {
  if (v == nullptr) throw ConfigError(path + ": missing");
  if (!v->is_array() || v->empty()) throw ConfigError(path + ": expected a non-empty array of column names");
  if (static_cast<long>(v->size()) > kMaxMimoChannels) throw ConfigError(path + ": more than " + std::to_string(kMaxMimoChannels) + " channels");
  std::vector<std::string> names;
  std::set<std::string> seen;
  for (std::size_t i = 0; i < v->size(); ++i) {
    const std::string where = path + "[" + std::to_string(i) + "]";
    if (!(*v)[i].is_string() || (*v)[i].get<std::string>().empty()) throw ConfigError(where + ": expected a non-empty name");
    names.push_back((*v)[i].get<std::string>());
    if (!seen.insert(names.back()).second) throw ConfigError(where + ": duplicate name \"" + names.back() + "\"");
  }
  return names;
}

}  // namespace

nlohmann::json mimo_model_to_json(const MimoModel& m) {
  return {
      {"format", kModelFormat},
      {"kind", kMimoKind},
      {"fs", m.fs},
      {"inputs", m.inputs},
      {"outputs", m.outputs},
      {"params",
       {{"order", m.ss.order()}, {"A", to_rows(m.ss.A)}, {"B", to_rows(m.ss.B)}, {"C", to_rows(m.ss.C)}, {"D", to_rows(m.ss.D)}}},
      {"meta", m.meta.is_null() ? nlohmann::json::object() : m.meta},
  };
}

MimoModel mimo_model_from_json(const nlohmann::json& j) {
  MimoModel m;
  JsonFields top(j, "model");
  m.fs = read_model_header(top, kMimoKind);
  m.inputs = read_channel_names(top.member("inputs"), "model.inputs");
  m.outputs = read_channel_names(top.member("outputs"), "model.outputs");
  const nlohmann::json* params = top.member("params");
  if (params == nullptr) throw ConfigError("model.params: missing");
  JsonFields p(*params, "model.params");
  const Eigen::Index n = p.integer("order", -1, 0, kMaxMimoOrder);
  if (n < 0) throw ConfigError("model.params.order: missing");
  const auto m_in = static_cast<Eigen::Index>(m.inputs.size()), p_out = static_cast<Eigen::Index>(m.outputs.size());
  const auto matrix = [&](const char* name, Eigen::Index rows, Eigen::Index cols) {
    const nlohmann::json* v = p.member(name);
    const std::string where = std::string("model.params.") + name;
    if (v == nullptr) throw ConfigError(where + ": missing");
    return read_matrix(*v, where, rows, cols);
  };
  m.ss.A = matrix("A", n, n);
  m.ss.B = matrix("B", n, m_in);
  m.ss.C = matrix("C", p_out, n);
  m.ss.D = matrix("D", p_out, m_in);
  p.finish();
  m.meta = read_model_meta(top);
  top.finish();
  const double radius = spectral_radius(m.ss);
  if (!(radius < 1.0)) throw ConfigError("model: unstable, pole radius " + number_text(radius) + " (must be < 1)");
  return m;
}

void save_mimo_model(const std::filesystem::path& path, const MimoModel& m) { write_json_file(path, mimo_model_to_json(m)); }

MimoModel load_mimo_model(const std::filesystem::path& path) {
  return read_json_file_as(path, mimo_model_from_json);
}

}  // namespace panelbass::models

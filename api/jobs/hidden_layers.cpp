#include "api/jobs/hidden_layers.h"

namespace panelbass::api {

std::vector<long long> hidden_layers(ParamReader& r, const std::vector<long long>& fallback) {
  return r.integers("hidden", fallback, 1, 4, 1, 256);
}

std::vector<int> hidden_widths(const nlohmann::json& list) {
  std::vector<int> out;
  for (const nlohmann::json& v : list) out.push_back(v.get<int>());
  return out;
}

std::string hidden_text(const std::vector<int>& hidden) {
  std::string text = "[";
  for (std::size_t k = 0; k < hidden.size(); ++k) text += (k ? "," : "") + std::to_string(hidden[k]);
  return text + "]";
}

}  // namespace panelbass::api

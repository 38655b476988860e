#include "api/jobs/param_reader.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "api/model_store.h"
#include "models/io/number_text.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

// `params` as the object to read: null counts as {}; anything else but an object is refused.
json object_at(const json& params, const std::string& path) {
  if (params.is_null()) return json::object();
  if (!params.is_object()) refuse(path, "expected an object, got " + std::string(params.type_name()));
  return params;
}

// `value` as an integer (an integral float such as 1e4 counts), or nullopt.
std::optional<long long> integral(const json& value) {
  if (value.is_number_integer()) {
    constexpr auto kLargest = static_cast<unsigned long long>(std::numeric_limits<long long>::max());
    if (value.is_number_unsigned() && value.get<unsigned long long>() > kLargest) return std::nullopt;
    return value.get<long long>();
  }
  if (value.is_number_float()) {
    const double d = value.get<double>();
    if (std::isfinite(d) && d == std::floor(d) && std::abs(d) < 9.0e15) return static_cast<long long>(d);
  }
  return std::nullopt;
}

std::string list_text(const std::vector<std::string>& names) {
  std::string text;
  for (std::size_t k = 0; k < names.size(); ++k) text += (k ? ", " : "") + ("\"" + names[k] + "\"");
  return text;
}

}  // namespace

void refuse(const std::string& path, const std::string& what) { throw std::invalid_argument(path + ": " + what); }

std::string shown(const json& value) {
  std::string text = value.dump();
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return text;
}

// ----- Interval --------------------------------------------------------------------------------------

bool Interval::contains(double v) const {
  const bool above = lo_open ? v > lo : v >= lo;
  const bool below = hi_open ? v < hi : v <= hi;
  return above && below;
}

std::string Interval::text() const {
  return std::string(lo_open ? "(" : "[") + models::number_text(lo) + ", " + models::number_text(hi) + (hi_open ? ")" : "]");
}

// ----- ParamReader -----------------------------------------------------------------------------------

ParamReader::ParamReader(const json& params, std::string path)
    : params_(object_at(params, path)), fields_(params_, std::move(path)) {}

std::string ParamReader::path_of(const std::string& key) const { return fields_.path_of(key); }

long long ParamReader::integer(const std::string& key, long long fallback, long long lo, long long hi) {
  const json* v = fields_.member(key);
  long long value = fallback;
  if (v != nullptr) {
    const std::optional<long long> i = integral(*v);
    const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    if (!i) refuse(path_of(key), "must be an integer in " + range + ", got " + shown(*v));
    if (*i < lo || *i > hi) refuse(path_of(key), "must be an integer in " + range + ", got " + std::to_string(*i));
    value = *i;
  }
  filled_[key] = value;
  return value;
}

double ParamReader::number(const std::string& key, double fallback, const Interval& range) {
  const json* v = fields_.member(key);
  double value = fallback;
  if (v != nullptr) {
    if (!v->is_number() || !std::isfinite(v->get<double>())) {
      refuse(path_of(key), "must be a number in " + range.text() + ", got " + shown(*v));
    }
    value = v->get<double>();
    if (!range.contains(value)) refuse(path_of(key), "must be a number in " + range.text() + ", got " + shown(*v));
  }
  filled_[key] = value;
  return value;
}

bool ParamReader::boolean(const std::string& key, bool fallback) {
  const json* v = fields_.member(key);
  if (v != nullptr && !v->is_boolean()) refuse(path_of(key), "expected true or false, got " + shown(*v));
  const bool value = v != nullptr ? v->get<bool>() : fallback;
  filled_[key] = value;
  return value;
}

std::string ParamReader::text(const std::string& key, const std::string& fallback) {
  const json* v = fields_.member(key);
  if (v != nullptr && !v->is_null() && !v->is_string()) refuse(path_of(key), "expected a string, got " + shown(*v));
  const std::string value = v != nullptr && v->is_string() ? v->get<std::string>() : fallback;
  filled_[key] = value;
  return value;
}

std::string ParamReader::choice(const std::string& key, const std::string& fallback, const std::vector<std::string>& choices) {
  const json* v = fields_.member(key);
  std::string value = fallback;
  if (v != nullptr) {
    if (!v->is_string() || std::find(choices.begin(), choices.end(), v->get<std::string>()) == choices.end()) {
      refuse(path_of(key), "must be one of " + list_text(choices) + ", got " + shown(*v));
    }
    value = v->get<std::string>();
  }
  filled_[key] = value;
  return value;
}

std::vector<std::string> ParamReader::texts(const std::string& key, const std::vector<std::string>& fallback) {
  const json* v = fields_.member(key);
  std::vector<std::string> value = fallback;
  if (v != nullptr && !v->is_null()) {
    if (!v->is_array() || std::any_of(v->begin(), v->end(), [](const json& s) { return !s.is_string(); })) {
      refuse(path_of(key), "expected a list of strings, got " + shown(*v));
    }
    value = v->get<std::vector<std::string>>();
  }
  filled_[key] = value;
  return value;
}

std::vector<long long> ParamReader::integers(const std::string& key, const std::vector<long long>& fallback,
                                             std::size_t min_count, std::size_t max_count, long long lo, long long hi) {
  const json* v = fields_.member(key);
  std::vector<long long> values = fallback;
  if (v != nullptr) {
    const std::string expected = (min_count == max_count ? std::to_string(min_count)
                                                         : std::to_string(min_count) + " to " + std::to_string(max_count)) +
                                 " integers in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    if (!v->is_array() || v->size() < min_count || v->size() > max_count) {
      refuse(path_of(key), "must be a list of " + expected + ", got " + shown(*v));
    }
    values.clear();
    for (std::size_t k = 0; k < v->size(); ++k) {
      const std::optional<long long> i = integral((*v)[k]);
      if (!i || *i < lo || *i > hi) {
        refuse(path_of(key) + "[" + std::to_string(k) + "]", "must be an integer in [" + std::to_string(lo) + ", " +
                                                                  std::to_string(hi) + "], got " + shown((*v)[k]));
      }
      values.push_back(*i);
    }
  }
  filled_[key] = values;
  return values;
}

std::vector<double> ParamReader::numbers(const std::string& key, const std::vector<double>& fallback,
                                         std::size_t min_count, std::size_t max_count, const Interval& range) {
  const json* v = fields_.member(key);
  std::vector<double> values = fallback;
  if (v != nullptr) {
    if (!v->is_array() || v->size() < min_count || v->size() > max_count) {
      refuse(path_of(key), "must be a list of " + std::to_string(min_count) + " to " + std::to_string(max_count) +
                               " numbers in " + range.text() + ", got " + shown(*v));
    }
    values.clear();
    for (std::size_t k = 0; k < v->size(); ++k) {
      const json& e = (*v)[k];
      if (!e.is_number() || !std::isfinite(e.get<double>()) || !range.contains(e.get<double>())) {
        refuse(path_of(key) + "[" + std::to_string(k) + "]", "must be a number in " + range.text() + ", got " + shown(e));
      }
      values.push_back(e.get<double>());
    }
  }
  filled_[key] = values;
  return values;
}

std::vector<std::string> ParamReader::choices(const std::string& key, const std::vector<std::string>& fallback,
                                              const std::vector<std::string>& choices) {
  const json* v = fields_.member(key);
  std::vector<std::string> values = fallback;
  if (v != nullptr) {
    if (!v->is_array() || v->empty()) refuse(path_of(key), "must be a non-empty list of " + list_text(choices) + ", got " + shown(*v));
    values.clear();
    for (std::size_t k = 0; k < v->size(); ++k) {
      const json& e = (*v)[k];
      if (!e.is_string() || std::find(choices.begin(), choices.end(), e.get<std::string>()) == choices.end()) {
        refuse(path_of(key) + "[" + std::to_string(k) + "]", "must be one of " + list_text(choices) + ", got " + shown(e));
      }
      values.push_back(e.get<std::string>());
    }
  }
  filled_[key] = values;
  return values;
}

std::optional<std::string> ParamReader::id(const std::string& key, bool required) {
  const json* v = fields_.member(key);
  if (v == nullptr || v->is_null()) {
    if (required) refuse(path_of(key), "required");
    filled_[key] = nullptr;
    return std::nullopt;
  }
  if (!v->is_string() || !is_valid_id(v->get<std::string>())) {
    refuse(path_of(key), "must be an id (letters, digits, _ or -), got " + shown(*v));
  }
  filled_[key] = *v;
  return v->get<std::string>();
}

const json* ParamReader::member(const std::string& key) { return fields_.member(key); }

void ParamReader::set(const std::string& key, json value) {
  fields_.member(key);
  filled_[key] = std::move(value);
}

json ParamReader::finish() const {
  if (const std::optional<std::string> key = fields_.unknown_key()) refuse(path_of(*key), "unknown field");
  return filled_;
}

}  // namespace panelbass::api

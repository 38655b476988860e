#include "models/io/bounded_json.h"

#include <set>
#include <string>
#include <vector>

namespace panelbass::models {
namespace {

using json = nlohmann::json;

// nlohmann's own DOM builder behind a SAX filter that counts the depth and the keys of each open object.
class BoundedSax {
 public:
  BoundedSax(json& result, std::size_t max_depth) : dom_(result, true), max_depth_(max_depth) {}

  bool null() { return after_value(), dom_.null(); }
  bool boolean(bool value) { return after_value(), dom_.boolean(value); }
  bool number_integer(json::number_integer_t value) { return after_value(), dom_.number_integer(value); }
  bool number_unsigned(json::number_unsigned_t value) { return after_value(), dom_.number_unsigned(value); }
  bool number_float(json::number_float_t value, const json::string_t& text) {
    return after_value(), dom_.number_float(value, text);
  }
  bool string(json::string_t& value) { return after_value(), dom_.string(value); }
  bool binary(json::binary_t& value) { return after_value(), dom_.binary(value); }

  bool start_object(std::size_t elements) {
    open(true);
    return dom_.start_object(elements);
  }
  bool key(json::string_t& name) {
    Frame& frame = frames_.back();
    if (!frame.keys.insert(name).second) {
      const std::string object = path(frames_.size() - 1);
      throw JsonLimitError("duplicate key \"" + name + "\" in " +
                           (object.empty() ? std::string("the top-level object") : "the object at " + object) +
                           " (a key may appear once in an object)");
    }
    frame.key = name;
    return dom_.key(name);
  }
  bool end_object() {
    frames_.pop_back();
    after_value();
    return dom_.end_object();
  }
  bool start_array(std::size_t elements) {
    open(false);
    return dom_.start_array(elements);
  }
  bool end_array() {
    frames_.pop_back();
    after_value();
    return dom_.end_array();
  }

  template <class Exception>
  bool parse_error(std::size_t position, const std::string& last_token, const Exception& error) {
    return dom_.parse_error(position, last_token, error);
  }

 private:
  struct Frame {
    bool object = false;
    std::set<std::string> keys;  // an object's keys so far
    std::string key;             // the key being read (object)
    std::size_t index = 0;       // the element being read (array)
  };

  void open(bool object) {
    if (frames_.size() >= max_depth_) {
      throw JsonLimitError("nesting deeper than " + std::to_string(max_depth_) + " levels " + where());
    }
    frames_.push_back(Frame{object, {}, {}, 0});
  }

  // A value of the enclosing array is complete: the next one has the next index.
  void after_value() {
    if (!frames_.empty() && !frames_.back().object) ++frames_.back().index;
  }

  // "a.b[2].c": the key path through the first `levels` open values (the first few only, for a deep one).
  std::string path(std::size_t levels) const {
    std::string text;
    constexpr std::size_t kShown = 8;
    for (std::size_t k = 0; k < levels && k < kShown; ++k) {
      const Frame& f = frames_[k];
      text += f.object ? (text.empty() ? "" : ".") + f.key.substr(0, 40) : "[" + std::to_string(f.index) + "]";
    }
    if (levels > kShown) text += "…";
    return text;
  }

  // "at a.b[2].c" for the value being read, or "at the top level".
  std::string where() const {
    const std::string text = path(frames_.size());
    return text.empty() ? "at the top level" : "at " + text;
  }

  nlohmann::detail::json_sax_dom_parser<json> dom_;
  std::size_t max_depth_;
  std::vector<Frame> frames_;
};

}  // namespace

json parse_bounded_json(std::string_view text, std::size_t max_depth) {
  json result;
  BoundedSax sax(result, max_depth);
  json::sax_parse(text.begin(), text.end(), &sax, json::input_format_t::json, true);
  return result;
}

}  // namespace panelbass::models

#include "api/routes/route_helpers.h"

#include <algorithm>
#include <charconv>
#include <system_error>
#include <utility>

#include "api/engine_service.h"
#include "api/job_queue.h"
#include "api/model_store.h"
#include "api/model_validation.h"
#include "api/request_body.h"

namespace panelbass::api {

void send_json(httplib::Response& res, int status, const nlohmann::json& body) {
  res.status = status;
  // Error messages may quote what a client sent, invalid UTF-8 included: replace it rather than throw.
  res.set_content(body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace), kJsonType);
}

void send_error(httplib::Response& res, int status, const std::string& code, const std::string& message) {
  send_json(res, status, {{"error", {{"code", code}, {"message", message}}}});
}

const char* code_of_status(int status) {
  switch (status) {
    case 400: return "bad_request";
    case 401: return "unauthorized";
    case 403: return "forbidden";
    case 404: return "not_found";
    case 405: return "method_not_allowed";
    case 408: return "timeout";
    case 409: return "conflict";
    case 413: return "too_large";
    case 415: return "unsupported_media_type";
    case 421: return "misdirected";
    case 422: return "invalid_model";
    case 429: return "too_many_jobs";
    case 431: return "too_large";
    case 503: return "unavailable";
    case 507: return "storage";
    default: return status >= 500 ? "internal" : "bad_request";
  }
}

void reject_unknown_fields(const nlohmann::json& object, std::initializer_list<const char*> allowed,
                           const std::string& where) {
  if (!object.is_object()) throw HttpError{400, "bad_request", where + ": expected a JSON object"};
  for (const auto& [key, value] : object.items()) {
    bool known = false;
    for (const char* name : allowed) known = known || key == name;
    if (!known) throw HttpError{400, "bad_request", (where.empty() ? "" : where + ".") + key + ": unknown field"};
  }
}

std::string path_id(const httplib::Request& req, const char* what) {
  const std::string id = req.matches[1];
  if (!is_valid_id(id)) {
    throw HttpError{400, "bad_request", std::string(what) + " id \"" + id +
                                             "\": ids are 1 to 64 letters, digits, '-' or '_'"};
  }
  return id;
}

std::string query_text(const httplib::Request& req, const char* key, std::size_t most_bytes) {
  if (!req.has_param(key)) return "";
  const std::string text = req.get_param_value(key);
  if (text.size() > most_bytes) {
    throw HttpError{400, "bad_request", std::string(key) + ": " + std::to_string(text.size()) + " bytes, at most " +
                                            std::to_string(most_bytes)};
  }
  // UTF-8 (RFC 3629): a lead byte, then as many continuation bytes as it says; no overlong forms, no
  // surrogates, nothing beyond U+10FFFF; and no control characters.
  for (std::size_t k = 0; k < text.size();) {
    const auto byte = [&](std::size_t at) { return at < text.size() ? static_cast<unsigned char>(text[at]) : 0u; };
    const unsigned lead = byte(k);
    std::size_t length = 0;
    unsigned low = 0x80, high = 0xBF;
    if (lead < 0x80) {
      length = lead < 0x20 || lead == 0x7F ? 0 : 1;
    } else if (lead >= 0xC2 && lead <= 0xDF) {
      length = 2;
    } else if (lead >= 0xE0 && lead <= 0xEF) {
      length = 3;
      if (lead == 0xE0) low = 0xA0;
      if (lead == 0xED) high = 0x9F;
    } else if (lead >= 0xF0 && lead <= 0xF4) {
      length = 4;
      if (lead == 0xF0) low = 0x90;
      if (lead == 0xF4) high = 0x8F;
    }
    bool valid = length > 0 && k + length <= text.size();
    for (std::size_t c = 1; valid && c < length; ++c) {
      const unsigned next = byte(k + c);
      valid = c == 1 ? next >= low && next <= high : next >= 0x80 && next <= 0xBF;
    }
    if (!valid) {
      throw HttpError{400, "bad_request", std::string(key) + ": not UTF-8 text (byte " + std::to_string(k) +
                                              (lead < 0x20 || lead == 0x7F ? " is a control character)" : " is not valid UTF-8)")};
    }
    k += length;
  }
  return text;
}

std::size_t query_count(const httplib::Request& req, const char* key, std::size_t fallback, std::size_t most) {
  if (!req.has_param(key)) return fallback;
  const std::string text = req.get_param_value(key);
  std::size_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || error != std::errc() || end != text.data() + text.size()) {
    throw HttpError{400, "bad_request", std::string(key) + ": expected an integer >= 0, got \"" + text + "\""};
  }
  return std::min(value, most);
}

nlohmann::json Page::answer(const char* key, nlohmann::json items, std::size_t total) const {
  return {{key, std::move(items)}, {"total", total}, {"offset", offset}, {"limit", limit}};
}

Page query_page(const httplib::Request& req, std::size_t total) {
  return {query_count(req, "offset", 0, total), query_count(req, "limit", kDefaultPageLimit, kMaxPageLimit)};
}

httplib::Server::Handler guarded(std::function<void(const httplib::Request&, httplib::Response&)> handler) {
  return [handler = std::move(handler)](const httplib::Request& req, httplib::Response& res) {
    try {
      handler(req, res);
    } catch (const HttpError& e) {
      send_error(res, e.status, e.code, e.message);
    } catch (const JobQueueFull& e) {
      res.set_header("Retry-After", "5");
      send_error(res, 429, "too_many_jobs", e.what());
    } catch (const EngineRequestError& e) {
      send_error(res, e.status(), e.code(), e.what());
    } catch (const ModelRejected& e) {
      send_error(res, e.code() == "invalid_model" ? 422 : 400, e.code(), e.what());
    } catch (const StoreError& e) {
      send_error(res, 507, "storage", e.what());
    } catch (const std::invalid_argument& e) {
      send_error(res, 400, "bad_request", e.what());
    } catch (const std::exception& e) {
      send_error(res, 500, "internal", e.what());
    }
  };
}

}  // namespace panelbass::api

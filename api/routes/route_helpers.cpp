#include "api/routes/route_helpers.h"

#include <algorithm>
#include <charconv>
#include <system_error>
#include <utility>

#include "api/engine_service.h"
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
    case 404: return "not_found";
    case 405: return "method_not_allowed";
    case 409: return "conflict";
    case 413: return "too_large";
    case 415: return "unsupported_media_type";
    case 422: return "invalid_model";
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

httplib::Server::Handler guarded(std::function<void(const httplib::Request&, httplib::Response&)> handler) {
  return [handler = std::move(handler)](const httplib::Request& req, httplib::Response& res) {
    try {
      handler(req, res);
    } catch (const HttpError& e) {
      send_error(res, e.status, e.code, e.message);
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

#include "api/request_body.h"

#include <httplib.h>

#include <string>

#include "models/io/bounded_json.h"

namespace panelbass::api {

// The request body as text: the body itself, or the one part of a multipart upload (curl -F model=@file).
std::string body_text(const httplib::Request& req) {
  if (!req.is_multipart_form_data()) return req.body;
  if (req.files.size() != 1) {
    throw HttpError{400, "bad_request", "body: a multipart upload must carry exactly one part (the JSON file), got " +
                                            std::to_string(req.files.size())};
  }
  return req.files.begin()->second.content;
}

// The request body as JSON. An empty body is `empty`, or, if that is null (the route needs a body),
// HttpError 400 saying what the body must be (`expected`).
nlohmann::json parse_body(const httplib::Request& req, const char* expected, const nlohmann::json& empty,
                          Overflow overflow) {
  const std::string text = body_text(req);
  if (text.empty()) {
    if (empty.is_null()) {
      throw HttpError{400, "bad_request", std::string("body: missing; ") + req.method + " " + req.path +
                                              " needs a JSON body: " + expected};
    }
    return empty;
  }
  try {
    return models::parse_bounded_json(text);
  } catch (const models::JsonLimitError& e) {
    throw HttpError{400, "bad_request", std::string("body: ") + e.what()};
  } catch (const nlohmann::json::parse_error& e) {
    throw HttpError{400, "bad_request", std::string("body: malformed JSON: ") + e.what()};
  } catch (const nlohmann::json::out_of_range& e) {
    // JSON has no NaN or infinity; a number beyond a double's range is the only way one can arrive.
    if (overflow == Overflow::invalid_model) {
      throw HttpError{422, "invalid_model", std::string("body: a number is not finite as a double: ") + e.what()};
    }
    throw HttpError{400, "bad_request", std::string("body: a number is beyond a double's range: ") + e.what()};
  } catch (const nlohmann::json::exception& e) {
    throw HttpError{400, "bad_request", std::string("body: ") + e.what()};
  }
}

// `bytes` as people write a size: "16 MiB", "64 KiB" or "1000 bytes".
std::string size_text(std::size_t bytes) {
  if (bytes >= (1u << 20) && bytes % (1u << 20) == 0) return std::to_string(bytes >> 20) + " MiB";
  if (bytes >= (1u << 10) && bytes % (1u << 10) == 0) return std::to_string(bytes >> 10) + " KiB";
  return std::to_string(bytes) + " bytes";
}

// Makes any request the API takes readable as cpp-httplib 0.11 reads it (it runs before the body is read):
// - no Content-Length and no Transfer-Encoding means no body (RFC 9112 §6.3; curl -X POST without -d sends
//   neither), where the library would wait for the connection to close and answer 400;
// - a body labelled application/x-www-form-urlencoded (curl -d/--data-binary's default) is JSON to this
//   API: left as that, the library refuses it above 8 KiB (its form limit) and parses it as a form.
// The request is the library's own (non-const) object, handed to this hook as const.
void accept_any_body(const httplib::Request& request) {
  auto& req = const_cast<httplib::Request&>(request);
  if (!req.has_header("Content-Length") && !req.has_header("Transfer-Encoding")) {
    req.headers.emplace("Content-Length", "0");
  }
  const auto type = req.headers.find("Content-Type");
  if (type != req.headers.end() && type->second.rfind("application/x-www-form-urlencoded", 0) == 0) {
    type->second = "application/json";
  }
}

// The message of an error the HTTP library answers by itself (before any route runs).
std::string library_error_message(const httplib::Request& req, int status, std::size_t body_limit) {
  switch (status) {
    case 400:
      return "the request could not be read: malformed HTTP (request line or headers), a method the API does not "
             "know, or a body that ended before its Content-Length";
    case 404: return "no such route: " + req.method + " " + req.path;
    case 405: return "method " + req.method + " not allowed on " + req.path;
    case 413: return "request body over the size limit of " + size_text(body_limit) + " (panelbass serve --body-limit)";
    case 414: return "request URI too long";
    default: return "HTTP status " + std::to_string(status) + " on " + req.method + " " + req.path;
  }
}

}  // namespace panelbass::api

#pragma once
// Reading an HTTP request's body as the API takes it: whatever content type curl sends, with or without a
// body, a multipart upload of one file; the JSON parsed with errors that say what the route needs; and the
// messages of the errors the HTTP library answers by itself.

#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>

namespace httplib {
struct Request;
}

namespace panelbass::api {

/// An error answered with {"error":{"code","message"}} and its status.
struct HttpError {
  int status;
  std::string code;
  std::string message;
};

/// What a number beyond a double's range (1e999) in a body means: a model that is not finite (422), or a
/// malformed request (400).
enum class Overflow { bad_request, invalid_model };

/// The request body as text: the body itself, or the one part of a multipart upload (curl -F model=@file).
std::string body_text(const httplib::Request& req);

/// The request body as JSON. An empty body is `empty`, or, if that is null (the route needs a body),
/// HttpError 400 saying what the body must be (`expected`).
nlohmann::json parse_body(const httplib::Request& req, const char* expected, const nlohmann::json& empty = nullptr,
                          Overflow overflow = Overflow::bad_request);

/// `bytes` as people write a size: "16 MiB", "64 KiB" or "1000 bytes".
std::string size_text(std::size_t bytes);

/// Makes any request the API takes readable by cpp-httplib 0.11 (runs before the body is read): no length
/// means no body, and a form-labelled body is JSON.
void accept_any_body(const httplib::Request& request);

/// The message of an error the HTTP library answers by itself (before any route runs).
std::string library_error_message(const httplib::Request& req, int status, std::size_t body_limit);

}  // namespace panelbass::api

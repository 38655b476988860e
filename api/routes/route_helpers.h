#pragma once
// What every route group of the server shares: the API's JSON replies and error object, the guard that
// turns a handler's exceptions into that object, and the path and query readers.

// Eigen before httplib.h: the latter's <resolv.h> defines _res, a name Eigen's headers use.
#include <Eigen/Core>
#include <cstddef>
#include <functional>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <string>

#include <httplib.h>

#include "api/http/guarded_http_server.h"

namespace panelbass::api {

/// The media type of every JSON reply.
inline constexpr const char* kJsonType = "application/json";

/// A list's page size unless the client names one.
inline constexpr std::size_t kDefaultPageLimit = 100;
/// The largest page size a client may name.
inline constexpr std::size_t kMaxPageLimit = 1000;

/// Replies `status` with `body` (invalid UTF-8 in it replaced, not thrown on).
void send_json(httplib::Response& res, int status, const nlohmann::json& body);

/// Replies `status` with the API's error object {"error":{"code","message"}}.
void send_error(httplib::Response& res, int status, const std::string& code, const std::string& message);

/// The error object's code for an HTTP status ("bad_request", "not_found", …).
const char* code_of_status(int status);

/// Throws HttpError 400 naming the first field of `object` not in `allowed` (`where` is its key path), or
/// when `object` is not an object.
void reject_unknown_fields(const nlohmann::json& object, std::initializer_list<const char*> allowed,
                           const std::string& where);

/// The id in the path's first capture; HttpError 400 naming `what` ("model", "job", …) when it is not an id.
std::string path_id(const httplib::Request& req, const char* what);

/// The query's text parameter `key` ("" when absent); HttpError 400 naming it when it is longer than
/// `most_bytes`, not UTF-8 or holds a control character (it is stored and shown as text).
std::string query_text(const httplib::Request& req, const char* key, std::size_t most_bytes = 256);

/// The query's non-negative integer `key` (at most `most`), or `fallback` when absent; HttpError 400 naming it
/// otherwise.
std::size_t query_count(const httplib::Request& req, const char* key, std::size_t fallback, std::size_t most);

/// A page of a list of `total` items: the query's offset (at most `total`) and limit (kDefaultPageLimit unless
/// given, at most kMaxPageLimit); HttpError 400 naming a bad one.
struct Page {
  std::size_t offset = 0;  ///< the first item
  std::size_t limit = 0;   ///< how many at most
  /// The list's answer: {key: items, "total", "offset", "limit"}.
  nlohmann::json answer(const char* key, nlohmann::json items, std::size_t total) const;
};
/// The page of a list of `total` items the query asks for.
Page query_page(const httplib::Request& req, std::size_t total);

/// A route handler that turns every exception it throws into the API's error object (HttpError, the engine's,
/// the model validator's and the store's with their own status; std::invalid_argument 400; the rest 500).
httplib::Server::Handler guarded(std::function<void(const httplib::Request&, httplib::Response&)> handler);

}  // namespace panelbass::api

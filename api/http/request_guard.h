#pragma once
// The checks every request passes before a route runs (docs/server.md "Security"): the Host header names this
// server (no DNS rebinding), a state change comes from the server's own origin or an allowed one (no
// cross-site request forgery), a JSON route gets a JSON body, a declared body fits the limit, and OPTIONS is
// answered on purpose (a preflight for an allowed origin, 403 for any other).

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

// Eigen before httplib.h: the latter's <resolv.h> defines _res, a name Eigen's headers use.
#include <Eigen/Core>
#include <httplib.h>

#include "api/request_body.h"

namespace panelbass::api {

/// Who may talk to the server besides curl on the same machine.
struct OriginPolicy {
  std::string bind = "127.0.0.1";             ///< the address the server listens on
  std::vector<std::string> allowed_origins;   ///< origins besides its own that may change state ("https://panel.example")
  std::vector<std::string> allowed_hosts;     ///< Host names besides the bound address and localhost ("panel.example")
};

/// The host part of a Host header or an origin's authority, lower-cased, without port or IPv6 brackets
/// ("[::1]:8080" → "::1").
std::string host_name_of(const std::string& authority);

/// "https://panel.example" or "http://127.0.0.1:8080" as browsers write an origin (lower-case scheme and host,
/// no path or trailing slash); throws std::invalid_argument naming `origin` when it is not one.
std::string normalized_origin(const std::string& origin);

/// The request's refusal before any route runs, or nullopt if it may go on. In order: a foreign Host (421),
/// a state change (POST, PUT, PATCH, DELETE) from a foreign Origin or a cross-site fetch (403), a JSON route's
/// body of another type (415), a declared body over `body_limit` (413). A browser's request (one with an
/// Origin or Sec-Fetch-Site header) must label JSON as JSON; curl's default label for -d is let through.
std::optional<HttpError> refusal(const httplib::Request& req, const OriginPolicy& policy, std::size_t body_limit);

/// Answers OPTIONS in `res`: 204 with the CORS preflight headers for an allowed origin, 204 with Allow for a
/// request without Origin; for a foreign origin returns the 403 to send instead (no CORS headers).
std::optional<HttpError> answer_options(const httplib::Request& req, httplib::Response& res,
                                        const OriginPolicy& policy);

/// Adds Access-Control-Allow-Origin (and Vary) for a request from an origin on the allow list (never for
/// another origin: a foreign page cannot read the answers).
void add_cors_headers(const httplib::Request& req, httplib::Response& res, const OriginPolicy& policy);

}  // namespace panelbass::api

#include "api/http/request_guard.h"

#include <arpa/inet.h>

#include <algorithm>
#include <cctype>
#include <regex>
#include <stdexcept>

namespace panelbass::api {
namespace {

std::string lower_case(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

bool is_ip_literal(const std::string& name) {
  unsigned char address[16];
  return inet_pton(AF_INET, name.c_str(), address) == 1 || inet_pton(AF_INET6, name.c_str(), address) == 1;
}

bool is_loopback_name(const std::string& name) { return name == "localhost" || name == "127.0.0.1" || name == "::1"; }

// True when the Host header's name is this server's: loopback, the bound address, an allowed name (or an
// allowed origin's), or — when it listens beyond loopback, behind its token — any address literal.
bool host_allowed(const std::string& host_header, const OriginPolicy& policy) {
  if (host_header.empty()) return true;  // HTTP/1.0 without Host: not a browser
  const std::string name = host_name_of(host_header);
  const std::string bind = lower_case(policy.bind);
  if (is_loopback_name(name) || name == bind) return true;
  for (const std::string& allowed : policy.allowed_hosts) {
    if (name == host_name_of(allowed)) return true;
  }
  for (const std::string& origin : policy.allowed_origins) {
    const std::size_t start = origin.find("://");
    if (start != std::string::npos && name == host_name_of(origin.substr(start + 3))) return true;
  }
  return !is_loopback_name(bind) && is_ip_literal(name);
}

bool on_allow_list(const std::string& origin, const OriginPolicy& policy) {
  const std::string normal = lower_case(origin);
  return std::any_of(policy.allowed_origins.begin(), policy.allowed_origins.end(),
                     [&](const std::string& allowed) { return lower_case(allowed) == normal; });
}

// The origin is the server's own: its authority is the Host the request was sent to (already checked to be
// this server's name), as a page the server itself served sends it.
bool own_origin(const httplib::Request& req, const std::string& origin) {
  const std::string normal = lower_case(origin);
  const std::string host = lower_case(req.get_header_value("Host"));
  if (host.empty()) return false;
  return normal == "http://" + host || normal == "https://" + host;
}

bool origin_allowed(const httplib::Request& req, const std::string& origin, const OriginPolicy& policy) {
  return own_origin(req, origin) || on_allow_list(origin, policy);
}

bool changes_state(const std::string& method) { return method != "GET" && method != "HEAD" && method != "OPTIONS"; }

// The routes whose body is JSON (POST /api/records takes a WAV or CSV file instead).
bool json_route(const httplib::Request& req) {
  if (req.method != "POST" && req.method != "PUT" && req.method != "PATCH") return false;
  if (req.path == "/api/jobs" || req.path == "/api/config" || req.path == "/api/models" ||
      req.path == "/api/program") return true;
  static const std::regex activate(R"(/api/models/[^/]+/activate)");
  return std::regex_match(req.path, activate);
}

bool has_body(const httplib::Request& req) {
  if (req.has_header("Transfer-Encoding")) return true;
  const std::string length = req.get_header_value("Content-Length");
  return !length.empty() && length.find_first_not_of('0') != std::string::npos;
}

// A request made by a browser (fetch, a form, a script): it names where it comes from.
bool from_browser(const httplib::Request& req) {
  return req.has_header("Origin") || req.has_header("Sec-Fetch-Site") || req.has_header("Sec-Fetch-Mode");
}

std::string media_type_of(const httplib::Request& req) {
  std::string type = lower_case(req.get_header_value("Content-Type"));
  type = type.substr(0, type.find(';'));
  const auto not_space = [](unsigned char c) { return !std::isspace(c); };
  type.erase(type.begin(), std::find_if(type.begin(), type.end(), not_space));
  type.erase(std::find_if(type.rbegin(), type.rend(), not_space).base(), type.end());
  return type;
}

bool json_type_accepted(const httplib::Request& req) {
  const std::string type = media_type_of(req);
  if (type == "application/json" || (type.size() > 5 && type.ends_with("+json"))) return true;
  if (type == "multipart/form-data" && req.path == "/api/models") return true;  // curl -F model=@file
  // curl -d labels its body application/x-www-form-urlencoded, and printf … | curl --data-binary @- too;
  // a browser never sends a JSON route such a body from a page of this server (web/api.js labels it JSON).
  return !from_browser(req) && (type.empty() || type == "application/x-www-form-urlencoded");
}

constexpr const char* kMethods = "GET, HEAD, POST, PUT, PATCH, DELETE, OPTIONS";

}  // namespace

std::string host_name_of(const std::string& authority) {
  std::string name = authority;
  if (!name.empty() && name.front() == '[') {
    const std::size_t close = name.find(']');
    name = name.substr(1, close == std::string::npos ? std::string::npos : close - 1);
  } else if (std::count(name.begin(), name.end(), ':') == 1) {
    name = name.substr(0, name.find(':'));
  }
  name = lower_case(name);
  if (!name.empty() && name.back() == '.') name.pop_back();
  return name;
}

std::string normalized_origin(const std::string& origin) {
  static const std::regex shape(R"(^(https?)://(\[[0-9a-fA-F:.]+\]|[A-Za-z0-9.-]+)(:[0-9]{1,5})?/?$)");
  std::smatch parts;
  if (!std::regex_match(origin, parts, shape)) {
    throw std::invalid_argument("--allow-origin " + origin +
                                ": expected an origin, scheme://host[:port] (e.g. https://panel.example)");
  }
  return lower_case(parts[1].str() + "://" + parts[2].str() + parts[3].str());
}

std::optional<HttpError> refusal(const httplib::Request& req, const OriginPolicy& policy, std::size_t body_limit) {
  const std::string host = req.get_header_value("Host");
  if (!host_allowed(host, policy)) {
    return HttpError{421, "misdirected",
                     "Host \"" + host + "\" is not a name of this server (localhost, its address " + policy.bind +
                         ", or a name given with serve --allow-host): a page that reached it through another "
                         "name (DNS rebinding) may not use it"};
  }
  if (changes_state(req.method)) {
    const std::string origin = req.get_header_value("Origin");
    const std::string site = lower_case(req.get_header_value("Sec-Fetch-Site"));
    if (!origin.empty() && !origin_allowed(req, origin, policy)) {
      return HttpError{403, "cross_origin",
                       "Origin " + origin + " may not change this server's state: only its own pages may (and "
                       "origins given with serve --allow-origin)"};
    }
    if (origin.empty() && (site == "cross-site" || site == "same-site")) {
      return HttpError{403, "cross_origin",
                       "a " + site + " request (Sec-Fetch-Site) may not change this server's state: only its own "
                       "pages may (and origins given with serve --allow-origin)"};
    }
  }
  if (json_route(req) && has_body(req) && !json_type_accepted(req)) {
    const std::string type = req.get_header_value("Content-Type");
    return HttpError{415, "unsupported_media_type",
                     "Content-Type " + (type.empty() ? std::string("(none)") : type) + ": " + req.method + " " +
                         req.path + " takes a JSON body (Content-Type: application/json)"};
  }
  if (req.has_header("Content-Length")) {
    const std::string text = req.get_header_value("Content-Length");
    const bool digits = !text.empty() && text.size() <= 19 && text.find_first_not_of("0123456789") == std::string::npos;
    if (!digits || std::stoull(text) > body_limit) {
      return HttpError{413, "too_large",
                       "request body of " + text + " bytes (Content-Length) is over the size limit of " +
                           size_text(body_limit) + " (panelbass serve --body-limit)"};
    }
  }
  return std::nullopt;
}

std::optional<HttpError> answer_options(const httplib::Request& req, httplib::Response& res,
                                        const OriginPolicy& policy) {
  const std::string origin = req.get_header_value("Origin");
  if (!origin.empty() && !origin_allowed(req, origin, policy)) {
    return HttpError{403, "cross_origin",
                     "OPTIONS from " + origin + ": this origin may not use the API (serve --allow-origin names those "
                     "that may)"};
  }
  res.status = 204;
  res.set_header("Allow", kMethods);
  if (!origin.empty()) {
    res.set_header("Access-Control-Allow-Origin", origin);
    res.set_header("Access-Control-Allow-Methods", kMethods);
    res.set_header("Access-Control-Allow-Headers", "Authorization, Content-Type, Last-Event-ID");
    res.set_header("Access-Control-Max-Age", "600");
    res.set_header("Vary", "Origin");
  }
  return std::nullopt;
}

void add_cors_headers(const httplib::Request& req, httplib::Response& res, const OriginPolicy& policy) {
  const std::string origin = req.get_header_value("Origin");
  if (origin.empty() || !on_allow_list(origin, policy)) return;
  res.set_header("Access-Control-Allow-Origin", origin);
  res.set_header("Vary", "Origin");
}

}  // namespace panelbass::api

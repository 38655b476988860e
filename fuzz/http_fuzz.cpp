// libFuzzer target: the HTTP request bodies (and path ids) of the API's routes (api/server.h, ROUTES.md).
// One Server (port 0, store in a fresh folder in /dev/shm, engine on the real-time virtual transducer)
// is started once; each input picks a route from its first byte and sends the rest as the body over
// loopback with cpp-httplib's client. A bad request must be answered 4xx with the JSON error object
// {"error":{"code","message"}}: a 5xx, a non-JSON error or a failed connection aborts (a crash to libFuzzer).
//
// Input: byte 0 → route ((byte − '0') mod 13, so seeds start with a digit, or ':' ';' '<' for 10–12); routes with an id in the path
// take it from the bytes up to the first '\n' (percent-encoded, so the server sees the bytes as they are)
// and the body from the rest. Routes 9–11 write the request on a socket of their own, as no client library
// would (issue #57): 9 a chunked body whose chunk sizes the input's bytes choose, 10 a request sent slowly
// in pieces, 11 a body nested as deep as the input is long. Route 12 is PUT /api/program.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "fuzz/scratch_file.h"
#include "api/server.h"
#include "models/plant/plant_presets.h"

// After the project's (Eigen) headers: glibc's resolv.h, which httplib pulls in, defines a macro `_res`.
#include <httplib.h>

namespace {

namespace fs = std::filesystem;
using panelbass::api::Server;
using panelbass::api::ServerOptions;

Server* server = nullptr;                 // lives for the whole process
int port = 0;                             // the server's loopback port
fs::path store_folder;                    // removed at exit
std::unique_ptr<httplib::Client> client;  // kept alive between inputs

using panelbass::fuzz::scratch_base;

void fail(const std::string& what) {
  std::fprintf(stderr, "http_fuzz: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

std::string percent_encoded(std::string_view bytes) {
  static const char* const hex = "0123456789ABCDEF";
  std::string out;
  for (const char c : bytes) {
    const auto b = static_cast<unsigned char>(c);
    if ((b >= 'a' && b <= 'z') || (b >= 'A' && b <= 'Z') || (b >= '0' && b <= '9') || b == '-' || b == '_') {
      out += c;
    } else {
      out += '%';
      out += hex[b >> 4];
      out += hex[b & 15];
    }
  }
  return out;
}

void connect() {
  client = std::make_unique<httplib::Client>("127.0.0.1", port);
  client->set_keep_alive(true);
  client->set_tcp_nodelay(true);  // else Nagle and delayed ACKs cost ~40 ms per request
  client->set_connection_timeout(5, 0);
  client->set_read_timeout(60, 0);
  client->set_write_timeout(10, 0);
}

/// Sends one request; on a transport error retries once on a new connection (a kept-alive connection
/// the server has closed), then gives up.
httplib::Result send(const std::string& method, const std::string& path, const std::string& body) {
  for (int attempt = 0; attempt < 2; ++attempt) {
    httplib::Result r = method == "GET"      ? client->Get(path.c_str())
                        : method == "DELETE" ? client->Delete(path.c_str(), body, "application/json")
                        : method == "POST"   ? client->Post(path.c_str(), body, "application/json")
                        : method == "PUT"    ? client->Put(path.c_str(), body, "application/json")
                                             : client->Patch(path.c_str(), body, "application/json");
    if (r) return r;
    if (attempt == 1) fail(method + " " + path + ": connection failed: " + httplib::to_string(r.error()));
    connect();
  }
  std::abort();
}

/// Checks an answer: never 5xx; every 4xx carries {"error":{"code":string,"message":string}}.
nlohmann::json checked(const std::string& method, const std::string& path, int status, const std::string& text) {
  const nlohmann::json body = nlohmann::json::parse(text, nullptr, false);
  const std::string where = method + " " + path + " → " + std::to_string(status) + " " + text;
  if (status >= 500 || status < 200) fail(where);
  if (status >= 400) {
    const bool shaped = body.is_object() && body.contains("error") && body["error"].is_object() &&
                        body["error"].contains("code") && body["error"]["code"].is_string() &&
                        body["error"].contains("message") && body["error"]["message"].is_string();
    if (!shaped) fail("not the JSON error object: " + where);
  }
  return body;
}

nlohmann::json checked(const std::string& method, const std::string& path, const httplib::Result& r) {
  return checked(method, path, r->status, r->body);
}

/// Writes `pieces` of one request (Connection: close) on a new loopback connection, `pause` apart, and checks
/// the answer read until the server closes.
void raw_exchange(const std::string& method, const std::string& path, const std::vector<std::string>& pieces,
                  std::chrono::milliseconds pause = std::chrono::milliseconds(0)) {
  const int sock = ::socket(AF_INET, SOCK_STREAM, 0);
  if (sock < 0) fail("socket() failed");
  timeval timeout{60, 0};
  ::setsockopt(sock, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(sock, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) fail("connect() failed");
  for (const std::string& piece : pieces) {
    // A server that has answered early (a refused head, a body over the limit) stops reading: sending may fail.
    if (::send(sock, piece.data(), piece.size(), MSG_NOSIGNAL) < 0) break;
    if (pause.count() > 0) std::this_thread::sleep_for(pause);
  }
  std::string response;
  char buffer[4096];
  for (ssize_t n; (n = ::recv(sock, buffer, sizeof buffer, 0)) > 0;) response.append(buffer, static_cast<std::size_t>(n));
  ::close(sock);
  const std::size_t head_end = response.find("\r\n\r\n");
  if (response.size() < 12 || head_end == std::string::npos) fail(method + " " + path + ": no answer: " + response);
  checked(method, path, std::atoi(response.c_str() + 9), response.substr(head_end + 4));
}

/// The head of a request with a JSON body of `length` bytes (or chunked when `length` is npos).
std::string head_of(const std::string& method, const std::string& path, std::size_t length) {
  return method + " " + path + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
         "\r\nContent-Type: application/json\r\n" +
         (length == std::string::npos ? std::string("Transfer-Encoding: chunked") : "Content-Length: " + std::to_string(length)) +
         "\r\nConnection: close\r\n\r\n";
}

nlohmann::json request(const std::string& method, const std::string& path, const std::string& body) {
  return checked(method, path, send(method, path, body));
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const fs::path base = scratch_base();
  const fs::path folder = base / ("panelbass-http-fuzz-" + std::to_string(::getpid()));
  fs::remove_all(folder);
  fs::create_directories(folder);
  ServerOptions options;
  options.port = 0;
  options.store = folder / "store";
  options.http_threads = 4;
  options.engine.plant = panelbass::models::plant_preset("panel-exciter");
  options.engine.chain.fs = options.engine.plant.fs;
  options.engine.program.assign(3000, 0.0);
  options.log = [](const std::string&) {};
  server = new Server(std::move(options));
  port = server->start();
  store_folder = folder;
  // libFuzzer ends with exit(): stop the server's threads before static objects are destroyed.
  std::atexit([] {
    server->stop();
    std::error_code ignored;
    fs::remove_all(store_folder, ignored);
  });
  connect();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const unsigned route = static_cast<std::uint8_t>(data[0] - '0') % 13;
  const std::string_view rest(reinterpret_cast<const char*>(data + 1), size - 1);
  const std::size_t newline = rest.find('\n');
  const std::string id = percent_encoded(rest.substr(0, newline));
  const std::string after_id(newline == std::string_view::npos ? std::string_view() : rest.substr(newline + 1));
  const std::string body(rest);

  switch (route) {
    case 0: request("POST", "/api/models", body); break;
    case 1: request("PUT", "/api/config", body); break;
    case 2: request("PATCH", "/api/config", body); break;
    case 3: {
      // A valid job would run; cancel it at once so that the queue stays short.
      const httplib::Result r = send("POST", "/api/jobs", body);
      const nlohmann::json answer = checked("POST", "/api/jobs", r);
      if (r->status == 202) {
        if (!answer.contains("id") || !answer["id"].is_string()) fail("POST /api/jobs: 202 without an id: " + r->body);
        request("DELETE", "/api/jobs/" + answer["id"].get<std::string>(), "");
      }
      break;
    }
    case 4: request("POST", "/api/models/" + id + "/activate", after_id); break;
    case 5: request("GET", "/api/jobs/" + id, ""); break;
    case 6: request("DELETE", "/api/jobs/" + id, ""); break;
    case 7: request("GET", "/api/models/" + id, ""); break;
    case 8: request("DELETE", "/api/models/" + id, ""); break;
    case 9: {
      // The body in chunks of 1 to 16 bytes, each size taken from the next byte of the input.
      std::vector<std::string> pieces = {head_of("POST", "/api/models", std::string::npos)};
      for (std::size_t at = 0; at < body.size();) {
        const std::size_t n = std::min<std::size_t>(1 + static_cast<std::uint8_t>(body[at]) % 16, body.size() - at);
        char size_line[16];
        std::snprintf(size_line, sizeof size_line, "%zx\r\n", n);
        pieces.push_back(size_line + body.substr(at, n) + "\r\n");
        at += n;
      }
      pieces.push_back("0\r\n\r\n");
      raw_exchange("POST", "/api/models (chunked)", pieces);
      break;
    }
    case 10: {
      // The whole request in at most 8 pieces, 1 ms apart.
      const std::string whole = head_of("PATCH", "/api/config", body.size()) + body;
      std::vector<std::string> pieces;
      const std::size_t step = std::max<std::size_t>(1, whole.size() / 8 + 1);
      for (std::size_t at = 0; at < whole.size(); at += step) pieces.push_back(whole.substr(at, step));
      raw_exchange("PATCH", "/api/config (slow)", pieces, std::chrono::milliseconds(1));
      break;
    }
    case 11: {
      // The input nested 16 levels per byte (past the parser's limit from the fifth byte on).
      std::string deep;
      const std::size_t levels = std::min<std::size_t>(16 * body.size(), 100000);
      for (std::size_t k = 0; k < levels; ++k) deep += "{\"a\":";
      deep += body;
      raw_exchange("POST", "/api/models (deep)", {head_of("POST", "/api/models", deep.size()) + deep});
      break;
    }
    case 12: request("PUT", "/api/program", body); break;
  }
  return 0;
}

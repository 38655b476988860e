#pragma once
// Requests as a browser, a hostile page or a slow client would send them, byte for byte, to the real server on
// a loopback port, and the answers with their headers (what the issue #57 tests look at: Access-Control-*,
// Connection, Retry-After).

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cctype>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

namespace panelbass::api::api_testing {

/// An answer with its head.
struct RawReply {
  int status = -1;        ///< -1: no answer (the connection was closed or reset first)
  std::string head;       ///< status line and headers
  nlohmann::json body;    ///< the body as JSON, or null
  std::string text;       ///< the body as sent

  /// The value of header `name` (case-insensitive; "" when absent).
  std::string header(const std::string& name) const {
    std::string lower_head = head, lower_name = name + ":";
    for (char& c : lower_head) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    for (char& c : lower_name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const std::size_t at = lower_head.find("\r\n" + lower_name);
    if (at == std::string::npos) return "";
    const std::size_t start = head.find_first_not_of(' ', at + 2 + lower_name.size());
    return head.substr(start, head.find("\r\n", start) - start);
  }
};

/// The text of an HTTP/1.1 request: `headers` in order after Host (127.0.0.1:`port` unless given), a
/// Content-Length for a non-empty `body` unless Transfer-Encoding is given, and Connection: close.
inline std::string http_request(const std::string& method, const std::string& path, int port,
                                const std::map<std::string, std::string>& headers = {}, const std::string& body = "") {
  std::string text = method + " " + path + " HTTP/1.1\r\n";
  if (!headers.count("Host")) text += "Host: 127.0.0.1:" + std::to_string(port) + "\r\n";
  for (const auto& [name, value] : headers) text += name + ": " + value + "\r\n";
  if (!body.empty() && !headers.count("Transfer-Encoding") && !headers.count("Content-Length")) {
    text += "Content-Length: " + std::to_string(body.size()) + "\r\n";
  }
  return text + "Connection: close\r\n\r\n" + body;
}

/// A connected loopback socket (reads time out after 30 s); -1 on failure.
inline int connect_loopback(int port) {
  const int sock = ::socket(AF_INET, SOCK_STREAM, 0);
  if (sock < 0) return -1;
  timeval timeout{30, 0};
  ::setsockopt(sock, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(sock, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    ::close(sock);
    return -1;
  }
  return sock;
}

/// Reads what the server sends on `sock` until it closes the connection (or 30 s pass) and parses it.
inline RawReply read_reply(int sock) {
  std::string response;
  char buffer[4096];
  for (ssize_t n; (n = ::recv(sock, buffer, sizeof buffer, 0)) > 0;) response.append(buffer, static_cast<std::size_t>(n));
  RawReply out;
  const std::size_t space = response.find(' ');
  const std::size_t head_end = response.find("\r\n\r\n");
  if (space == std::string::npos || head_end == std::string::npos) {
    out.text = response;
    return out;
  }
  out.status = std::stoi(response.substr(space + 1, 3));
  out.head = response.substr(0, head_end + 2);
  out.text = response.substr(head_end + 4);
  out.body = nlohmann::json::parse(out.text, nullptr, false);
  if (out.body.is_discarded()) out.body = nullptr;
  return out;
}

/// Sends `request` whole on a new connection and reads the answer.
inline RawReply send_raw(int port, const std::string& request) {
  const int sock = connect_loopback(port);
  if (sock < 0) return {};
  std::size_t sent = 0;
  while (sent < request.size()) {
    const ssize_t n = ::send(sock, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;
    sent += static_cast<std::size_t>(n);
  }
  const RawReply reply = read_reply(sock);
  ::close(sock);
  return reply;
}

}  // namespace panelbass::api::api_testing

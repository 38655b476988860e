#pragma once
// cpp-httplib's server with the bounds a hostile or merely slow client cannot get around: every connection on
// a thread of its own up to a limit (beyond it a 503, so a few stalled clients never starve /api/health), a
// deadline for a request's head and one for its body, a cap on the head's size, every body byte counted
// (chunked framing included) and reading stopped at the limit, and a bounded number of requests and idle time
// per kept-alive connection. The routes, pre-routing checks and error replies stay cpp-httplib's.

#include <sys/types.h>

#include <chrono>
#include <cstddef>
#include <string>

// Eigen before httplib.h: the latter's <resolv.h> defines _res, a name Eigen's headers use.
#include <Eigen/Core>
#include <httplib.h>

namespace panelbass::api {

/// What one connection and one request may take.
struct HttpLimits {
  std::size_t body_bytes = 16u << 20;           ///< bytes after the head (a chunked body's framing included)
  std::size_t head_bytes = 64u << 10;           ///< request line and headers together
  std::chrono::milliseconds head_timeout{10000};  ///< from a request's first byte to the end of its head
  std::chrono::milliseconds body_timeout{60000};  ///< from the end of the head to the end of the body
  std::chrono::milliseconds idle_timeout{5000};   ///< a kept-alive connection's wait for its next request
  std::chrono::milliseconds write_timeout{5000};  ///< a stalled reader of a response
  std::size_t requests_per_connection = 100;    ///< then the connection is closed
  std::size_t max_connections = 64;             ///< served at once (a thread each); more are answered 503
};

/// Why the current request could not be read to its end (the error handler's 400 becomes 413, 408 or 431).
enum class ReadFailure { none, head_too_large, head_timeout, body_too_large, body_timeout };

/// The status that answers a request cut short by `failure`: 431 (head too large), 408 (a deadline), 413 (body).
int read_failure_status(ReadFailure failure);

/// What to tell the client whose request was cut short by `failure` (`body_limit` in bytes).
std::string read_failure_message(ReadFailure failure, std::size_t body_limit);

/// The HTTP server, its connections bounded by HttpLimits.
class GuardedHttpServer : public httplib::Server {
 public:
  /// A server whose connections keep `limits`.
  explicit GuardedHttpServer(const HttpLimits& limits);

  /// The limits.
  const HttpLimits& limits() const { return limits_; }

  /// Why the request being handled on this thread failed to be read (none outside a request).
  static ReadFailure current_read_failure();

 private:
  bool process_and_close_socket(socket_t sock) override;

  HttpLimits limits_;
};

}  // namespace panelbass::api

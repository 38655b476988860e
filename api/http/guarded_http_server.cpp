#include "api/http/guarded_http_server.h"

#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "api/request_body.h"

namespace panelbass::api {
namespace {

using Clock = std::chrono::steady_clock;

// The longest a wait sleeps before it looks again whether the server is stopping.
constexpr std::chrono::milliseconds kStopCheck{100};

// One connection's socket as cpp-httplib reads it: buffered, every byte of a request's head and body counted
// against its cap, every wait bounded by the phase's deadline (and cut short when the server stops).
class ConnectionStream final : public httplib::Stream {
 public:
  ConnectionStream(socket_t sock, const HttpLimits& limits, const std::atomic<socket_t>& server_socket)
      : sock_(sock), limits_(limits), server_socket_(server_socket) {}

  // Waits up to the idle timeout for the next request's first byte; false when it did not come, the peer
  // closed or the server stops.
  bool await_request() {
    if (pos_ < end_) return true;
    return wait_readable(Clock::now() + limits_.idle_timeout);
  }
  // A request's head starts: its deadline and byte cap apply.
  void begin_head() { begin(Phase::head, limits_.head_timeout); }
  // The head has been read: the body's deadline and byte cap apply.
  void begin_body() { begin(Phase::body, limits_.body_timeout); }
  // Why reading stopped short (none if it did not).
  ReadFailure failure() const { return failure_; }

  bool is_readable() const override {
    if (pos_ < end_) return true;
    pollfd p{sock_, POLLIN, 0};
    return ::poll(&p, 1, 0) > 0;
  }
  bool is_writable() const override {
    pollfd p{sock_, POLLOUT, 0};
    const int ms = static_cast<int>(limits_.write_timeout.count());
    return ::poll(&p, 1, ms) > 0 && (p.revents & (POLLERR | POLLHUP)) == 0;
  }

  ssize_t read(char* ptr, size_t size) override {
    if (failure_ != ReadFailure::none) return -1;
    const std::size_t cap = phase_ == Phase::head ? limits_.head_bytes : limits_.body_bytes;
    if (counted_ >= cap) {
      failure_ = phase_ == Phase::head ? ReadFailure::head_too_large : ReadFailure::body_too_large;
      return -1;
    }
    if (pos_ == end_) {
      for (;;) {
        if (!wait_readable(deadline_)) {
          if (failure_ == ReadFailure::none && Clock::now() >= deadline_) {
            failure_ = phase_ == Phase::head ? ReadFailure::head_timeout : ReadFailure::body_timeout;
          }
          return -1;
        }
        const ssize_t n = ::recv(sock_, buffer_, sizeof buffer_, 0);
        if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
        if (n <= 0) return n;
        pos_ = 0;
        end_ = static_cast<std::size_t>(n);
        break;
      }
    }
    const std::size_t n = std::min({size, end_ - pos_, cap - counted_});
    std::memcpy(ptr, buffer_ + pos_, n);
    pos_ += n;
    counted_ += n;
    return static_cast<ssize_t>(n);
  }

  ssize_t write(const char* ptr, size_t size) override {
    for (;;) {
      if (!is_writable()) return -1;
      const ssize_t n = ::send(sock_, ptr, size, MSG_NOSIGNAL);
      if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
      return n;
    }
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override { address_of(true, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { address_of(false, ip, port); }
  socket_t socket() const override { return sock_; }

 private:
  enum class Phase { head, body };

  void begin(Phase phase, std::chrono::milliseconds timeout) {
    phase_ = phase;
    counted_ = 0;
    deadline_ = Clock::now() + timeout;
  }

  // Waits until the socket is readable (true) or `until` passed, the server stops or polling fails (false).
  bool wait_readable(Clock::time_point until) const {
    for (;;) {
      if (server_socket_.load() == INVALID_SOCKET) return false;
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now());
      if (left.count() <= 0) return false;
      pollfd p{sock_, POLLIN, 0};
      const int ready = ::poll(&p, 1, static_cast<int>(std::min(left, kStopCheck).count()) + 1);
      if (ready > 0) return true;
      if (ready < 0 && errno != EINTR) return false;
    }
  }

  void address_of(bool remote, std::string& ip, int& port) const {
    sockaddr_storage address{};
    socklen_t length = sizeof address;
    auto* raw = reinterpret_cast<sockaddr*>(&address);
    if ((remote ? ::getpeername(sock_, raw, &length) : ::getsockname(sock_, raw, &length)) != 0) return;
    char host[NI_MAXHOST];
    char service[NI_MAXSERV];
    if (::getnameinfo(raw, length, host, sizeof host, service, sizeof service, NI_NUMERICHOST | NI_NUMERICSERV) == 0) {
      ip = host;
      port = std::atoi(service);
    }
  }

  socket_t sock_;
  const HttpLimits& limits_;
  const std::atomic<socket_t>& server_socket_;
  char buffer_[4096];
  std::size_t pos_ = 0, end_ = 0;
  Phase phase_ = Phase::head;
  std::size_t counted_ = 0;
  Clock::time_point deadline_ = Clock::now();
  ReadFailure failure_ = ReadFailure::none;
};

// Set while the accepting thread answers a connection beyond the limit itself.
thread_local bool connection_refused_here = false;
// The stream of the request this thread is handling (for the error handler).
thread_local const ConnectionStream* connection_stream_here = nullptr;

// A thread per connection, started as needed, up to `most` at once; a connection beyond them is handed back to
// the accepting thread, marked refused, which answers 503 at once.
class ConnectionThreads final : public httplib::TaskQueue {
 public:
  explicit ConnectionThreads(std::size_t most) : most_(std::max<std::size_t>(most, 1)) {}
  ~ConnectionThreads() override { shutdown(); }

  void enqueue(std::function<void()> fn) override {
    {
      const std::lock_guard lock(mutex_);
      if (!stopping_ && busy_ + waiting_.size() < most_) {
        waiting_.push_back(std::move(fn));
        if (threads_.size() - busy_ < waiting_.size()) threads_.emplace_back([this] { work(); });
        changed_.notify_one();
        return;
      }
    }
    connection_refused_here = true;
    fn();
    connection_refused_here = false;
  }

  void shutdown() override {
    {
      const std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    changed_.notify_all();
    for (std::thread& t : threads_) {
      if (t.joinable()) t.join();
    }
  }

 private:
  void work() {
    std::unique_lock lock(mutex_);
    for (;;) {
      changed_.wait(lock, [this] { return stopping_ || !waiting_.empty(); });
      if (waiting_.empty()) return;
      std::function<void()> fn = std::move(waiting_.front());
      waiting_.pop_front();
      ++busy_;
      lock.unlock();
      fn();
      lock.lock();
      --busy_;
    }
  }

  const std::size_t most_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::function<void()>> waiting_;
  std::vector<std::thread> threads_;
  std::size_t busy_ = 0;
  bool stopping_ = false;
};

// Answers a connection beyond the limit with 503 without waiting for it, and closes it.
void refuse_connection(socket_t sock, std::size_t most) {
  const std::string body = R"({"error":{"code":"unavailable","message":"too many connections: the server serves )" +
                           std::to_string(most) + R"( at once; try again"}})";
  const std::string response = "HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/json\r\nContent-Length: " +
                               std::to_string(body.size()) + "\r\nRetry-After: 1\r\nConnection: close\r\n\r\n" + body;
  (void)::send(sock, response.data(), response.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  ::shutdown(sock, SHUT_WR);
  // What the client sent already, read so that closing does not reset the connection before it reads the 503.
  char scratch[4096];
  for (int k = 0; k < 16 && ::recv(sock, scratch, sizeof scratch, MSG_DONTWAIT) > 0; ++k) {
  }
  ::close(sock);
}

}  // namespace

int read_failure_status(ReadFailure failure) {
  switch (failure) {
    case ReadFailure::head_too_large: return 431;
    case ReadFailure::head_timeout:
    case ReadFailure::body_timeout: return 408;
    case ReadFailure::body_too_large: return 413;
    case ReadFailure::none: break;
  }
  return 400;
}

std::string read_failure_message(ReadFailure failure, std::size_t body_limit) {
  switch (failure) {
    case ReadFailure::head_too_large: return "request line and headers over their limit (64 KiB)";
    case ReadFailure::head_timeout: return "the request's headers did not arrive in time";
    case ReadFailure::body_timeout: return "the request body did not arrive in time";
    case ReadFailure::body_too_large:
      return "request body over the size limit of " + size_text(body_limit) +
             " (panelbass serve --body-limit; a chunked body counts with its framing); reading stopped there";
    case ReadFailure::none: break;
  }
  return "the request could not be read";
}

GuardedHttpServer::GuardedHttpServer(const HttpLimits& limits) : limits_(limits) {
  new_task_queue = [most = limits_.max_connections] { return new ConnectionThreads(most); };
  // The library's own reading path is not used (process_and_close_socket below), but its 413 for a declared
  // length stays as a second line.
  set_payload_max_length(limits_.body_bytes);
  set_keep_alive_max_count(limits_.requests_per_connection);
  set_keep_alive_timeout(std::max<time_t>(1, limits_.idle_timeout.count() / 1000));
}

ReadFailure GuardedHttpServer::current_read_failure() {
  return connection_stream_here ? connection_stream_here->failure() : ReadFailure::none;
}

bool GuardedHttpServer::process_and_close_socket(socket_t sock) {
  if (connection_refused_here) {
    refuse_connection(sock, limits_.max_connections);
    return false;
  }
  ConnectionStream stream(sock, limits_, svr_sock_);
  bool ok = false;
  for (std::size_t served = 0; served < limits_.requests_per_connection; ++served) {
    if (!stream.await_request()) break;
    stream.begin_head();
    bool closed = false;
    connection_stream_here = &stream;
    ok = process_request(stream, served + 1 == limits_.requests_per_connection, closed,
                         [&stream](httplib::Request&) { stream.begin_body(); });
    connection_stream_here = nullptr;
    if (!ok || closed || stream.failure() != ReadFailure::none) break;
  }
  ::shutdown(sock, SHUT_RDWR);
  ::close(sock);
  return ok;
}

}  // namespace panelbass::api

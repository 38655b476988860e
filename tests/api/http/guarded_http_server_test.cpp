// What a hostile or slow client can take from the server (issue #57, api/http/guarded_http_server.h), through the
// real server: a chunked body is counted and cut off at the limit, a declared one over it is refused unread,
// half-sent heads and open event streams never starve /api/health, a connection beyond the bound is answered
// 503 at once, and a stalled head is dropped at its deadline.
#include <gtest/gtest.h>

#include <atomic>
#include <string>
#include <thread>
#include <vector>

#include "tests/api/raw_http.h"
#include "tests/api/server_fixture.h"

namespace panelbass::api {
namespace {

using namespace api_testing;

TEST_F(ServerTest, AChunkedBodyIsCountedAndCutOffAtTheLimit) {
  ServerOptions o = options(dir_ / "store");
  o.body_limit = 1u << 20;
  start(std::move(o));
  // 8 MiB of CSV in 64 KiB chunks, sent on one thread while this one reads the answer.
  const int sock = connect_loopback(port_);
  ASSERT_GE(sock, 0);
  std::thread sender([sock, port = port_] {
    const std::string head = http_request("POST", "/api/records?fs=3000", port,
                                          {{"Transfer-Encoding", "chunked"}, {"Content-Type", "text/csv"}});
    std::string chunk(65536, '\n');
    chunk.replace(0, 4, "u,y\n");
    char size_line[32];
    std::snprintf(size_line, sizeof size_line, "%zx\r\n", chunk.size());
    const std::string piece = size_line + chunk + "\r\n";
    if (::send(sock, head.data(), head.size(), MSG_NOSIGNAL) < 0) return;
    for (int k = 0; k < 128; ++k) {
      if (::send(sock, piece.data(), piece.size(), MSG_NOSIGNAL) < 0) return;  // the server stopped reading
    }
    (void)::send(sock, "0\r\n\r\n", 5, MSG_NOSIGNAL);
  });
  const RawReply reply = read_reply(sock);
  ::shutdown(sock, SHUT_RDWR);
  sender.join();
  ::close(sock);
  EXPECT_EQ(reply.status, 413) << reply.text;
  EXPECT_EQ(reply.body["error"]["code"], "too_large") << reply.text;
  EXPECT_NE(reply.body["error"]["message"].get<std::string>().find("1 MiB"), std::string::npos) << reply.text;
  EXPECT_EQ(reply.header("Connection"), "close") << reply.head;
  EXPECT_EQ(get("/api/records").body["total"], 0);
  // A chunked body within the limit is read as any other.
  const std::string job = R"({"kind":"excite","params":{"samples":1000}})";
  char size_line[32];
  std::snprintf(size_line, sizeof size_line, "%zx\r\n", job.size());
  const RawReply small = send_raw(port_, http_request("POST", "/api/jobs", port_,
                                                      {{"Transfer-Encoding", "chunked"}, {"Content-Type", "application/json"}},
                                                      size_line + job + "\r\n0\r\n\r\n"));
  EXPECT_EQ(small.status, 202) << small.text;
}

TEST_F(ServerTest, ADeclaredBodyOverTheLimitIsRefusedUnread) {
  start();
  // A gigabyte announced and never sent: the answer cannot have waited for it.
  const RawReply r = send_raw(port_, http_request("POST", "/api/records?fs=3000", port_,
                                                  {{"Content-Length", std::to_string(1u << 30)}, {"Content-Type", "text/csv"}}));
  EXPECT_EQ(r.status, 413) << r.text;
  EXPECT_NE(r.body["error"]["message"].get<std::string>().find("16 MiB"), std::string::npos) << r.text;
}

TEST_F(ServerTest, HalfSentHeadsAndOpenEventStreamsLeaveHealthAnswering) {
  ServerOptions o = options(dir_ / "store");
  o.event_streams = 4;
  start(std::move(o));
  // 40 connections that send part of a head and wait (a thread each, within the server's 64).
  std::vector<int> held;
  for (int k = 0; k < 40; ++k) {
    const int sock = connect_loopback(port_);
    ASSERT_GE(sock, 0);
    const std::string part = "GET /api/health HTTP/1.1\r\nHost: 127.0.0.1";
    ASSERT_GT(::send(sock, part.data(), part.size(), MSG_NOSIGNAL), 0);
    held.push_back(sock);
  }
  // A job that stays running, and event streams on it: the fifth is refused, not queued behind the rest.
  std::atomic<bool> release{false};
  const std::string id = server_->jobs().submit("held", nlohmann::json::object(), job_held_until(release));
  for (int k = 0; k < 4; ++k) {
    const int sock = connect_loopback(port_);
    const std::string request = http_request("GET", "/api/jobs/" + id + "/events", port_);
    ASSERT_GT(::send(sock, request.data(), request.size(), MSG_NOSIGNAL), 0);
    held.push_back(sock);
  }
  // (The streams are open once their first event has come.)
  for (std::size_t k = held.size() - 4; k < held.size(); ++k) {
    char first[64];
    ASSERT_GT(::recv(held[k], first, sizeof first, 0), 0);
  }
  const RawReply fifth = send_raw(port_, http_request("GET", "/api/jobs/" + id + "/events", port_));
  EXPECT_EQ(fifth.status, 503) << fifth.text;
  EXPECT_NE(fifth.body["error"]["message"].get<std::string>().find("event streams"), std::string::npos) << fifth.text;
  const Reply health = get("/api/health");
  EXPECT_EQ(health.status, 200) << health.text;
  EXPECT_EQ(get("/api/status").status, 200);
  release = true;
  for (const int sock : held) ::close(sock);
}

TEST_F(ServerTest, AConnectionBeyondTheBoundIsAnswered503AndAStalledHeadIsDroppedAtItsDeadline) {
  ServerOptions o = options(dir_ / "store");
  o.http_threads = 4;
  o.head_timeout = 300ms;
  start(std::move(o));
  std::vector<int> held;
  for (int k = 0; k < 4; ++k) {
    const int sock = connect_loopback(port_);
    ASSERT_GE(sock, 0);
    ASSERT_GT(::send(sock, "GET /api/health HTTP/1.1\r\n", 26, MSG_NOSIGNAL), 0);
    held.push_back(sock);
  }
  // While the four stall, a fifth connection gets its answer at once rather than a place in a queue.
  const RawReply fifth = send_raw(port_, http_request("GET", "/api/health", port_));
  if (fifth.status != 200) {  // (unless a stalled head already reached its deadline)
    EXPECT_EQ(fifth.status, 503) << fifth.text;
    EXPECT_EQ(fifth.body["error"]["code"], "unavailable") << fifth.text;
    EXPECT_EQ(fifth.header("Retry-After"), "1") << fifth.head;
  }
  // Each stalled head is answered 408 at its deadline and closed: the read sees the end, not its 30 s timeout.
  for (const int sock : held) {
    const RawReply late = read_reply(sock);
    EXPECT_EQ(late.status, 408) << late.text;
    ::close(sock);
  }
  EXPECT_EQ(get("/api/health").status, 200);
}

TEST_F(ServerTest, ABodyThatStopsComingIsAnswered408AtItsDeadline) {
  ServerOptions o = options(dir_ / "store");
  o.body_timeout = 300ms;
  start(std::move(o));
  const int sock = connect_loopback(port_);
  ASSERT_GE(sock, 0);
  // 100 bytes announced, 10 sent.
  const std::string request = http_request("PATCH", "/api/config", port_,
                                           {{"Content-Type", "application/json"}, {"Content-Length", "100"}}) + R"({"band_pa)";
  ASSERT_GT(::send(sock, request.data(), request.size(), MSG_NOSIGNAL), 0);
  const RawReply late = read_reply(sock);
  ::close(sock);
  EXPECT_EQ(late.status, 408) << late.text;
  EXPECT_EQ(late.body["error"]["code"], "timeout") << late.text;
  EXPECT_EQ(get("/api/health").status, 200);
}

TEST_F(ServerTest, TheTokenIsCheckedBeforeABodyIsRead) {
  ServerOptions o = options(dir_ / "store");
  o.token = "s3cret";
  start(std::move(o));
  // A megabyte announced and never sent: the 401 cannot have waited for it.
  const RawReply r = send_raw(port_, http_request("POST", "/api/models", port_,
                                                  {{"Content-Type", "application/json"}, {"Content-Length", "1000000"}}));
  EXPECT_EQ(r.status, 401) << r.text;
  EXPECT_EQ(r.header("Connection"), "close") << r.head;
}

TEST_F(ServerTest, AKeptAliveConnectionServesABoundedNumberOfRequests) {
  start();
  const int sock = connect_loopback(port_);
  ASSERT_GE(sock, 0);
  const std::string request = "GET /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
  // One request at a time, each answer read whole before the next is sent, until the server closes.
  std::string all;
  std::size_t answers = 0;
  for (int k = 0; k < 150; ++k) {
    if (::send(sock, request.data(), request.size(), MSG_NOSIGNAL) <= 0) break;
    char buffer[4096];
    bool closed = false;
    while (!closed && all.find("\"version\"", all.rfind("HTTP/1.1")) == std::string::npos) {
      const ssize_t n = ::recv(sock, buffer, sizeof buffer, 0);
      if (n <= 0) closed = true; else all.append(buffer, static_cast<std::size_t>(n));
    }
    if (closed) break;
    ++answers;
    if (all.find("Connection: close") != std::string::npos) break;
    all.clear();
  }
  ::close(sock);
  EXPECT_EQ(answers, 100u);  // the hundredth answer says Connection: close
  EXPECT_NE(all.find("Connection: close"), std::string::npos) << all;
}

}  // namespace
}  // namespace panelbass::api

// Inputs that fuzz/http_fuzz.cpp found to break the API's error contract (ROUTES.md: a bad request is a 4xx
// with {"error":{"code","message"}}), kept byte for byte. Each one once gave 500 "internal".
// The cause: an error message that quotes the client's bytes (a parse error, a path id) may hold invalid
// UTF-8, and a strict dump() of the error object threw type_error.316 (fixed in send_json()).
#include <gtest/gtest.h>

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "api/server.h"
#include "models/plant/plant_presets.h"
#include "tests/support/scratch_directory.h"

// After the project's (Eigen) headers: glibc's resolv.h, which httplib pulls in, defines a macro `_res`.
#include <httplib.h>

namespace panelbass::api {
namespace {

class HttpFuzzRegressionTest : public testing_support::ScratchDirectoryTest {
 protected:
  void SetUp() override {
    ServerOptions o;
    o.port = 0;
    o.store = dir_ / "store";
    o.engine.plant = models::plant_preset("panel-exciter");
    o.engine.chain.fs = o.engine.plant.fs;
    o.log = [](const std::string&) {};
    server_ = std::make_unique<Server>(std::move(o));
    client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->start());
    client_->set_read_timeout(30, 0);
  }

  // Expects a 400 whose body is the JSON error object with code "bad_request" and a message containing
  // `names` (what was wrong and where).
  static void expect_bad_request(const httplib::Result& r, const std::string& names) {
    ASSERT_TRUE(r) << httplib::to_string(r.error());
    EXPECT_EQ(r->status, 400) << r->body;
    const nlohmann::json body = nlohmann::json::parse(r->body, nullptr, false);
    ASSERT_TRUE(body.is_object()) << r->body;
    EXPECT_EQ(body["error"].value("code", ""), "bad_request") << r->body;
    EXPECT_NE(body["error"].value("message", "").find(names), std::string::npos) << r->body;
  }

  std::unique_ptr<Server> server_;
  std::unique_ptr<httplib::Client> client_;
};

// crash-ac61999ab1c9e695076531a6bde755b2d9b6b452: malformed JSON whose parse error quotes an invalid UTF-8
// byte (0xEA); writing that message into the JSON error object threw type_error.316 → 500.
TEST_F(HttpFuzzRegressionTest, MalformedJsonWithInvalidUtf8IsABadRequest) {
  const std::string body =
      "{\"kind\":\"excite\",\"params\":{\"samples\":1000,\"validation_samples\":0,\"ampl\xea" "itude\":0.1}}";
  expect_bad_request(client_->Post("/api/jobs", body, "application/json"), "body: malformed JSON");
  expect_bad_request(client_->Post("/api/models", body, "application/json"), "body: malformed JSON");
  expect_bad_request(client_->Patch("/api/config", body, "application/json"), "body: malformed JSON");
}

// The same class through a path id: the message quotes the id, which may be any bytes.
TEST_F(HttpFuzzRegressionTest, InvalidUtf8InAPathIdIsABadRequest) {
  expect_bad_request(client_->Get("/api/jobs/j%FF1"), "job id");
  expect_bad_request(client_->Delete("/api/models/m%EA"), "model id");
  expect_bad_request(client_->Post("/api/models/%C3/activate", "", "application/json"), "model id");
}

}  // namespace
}  // namespace panelbass::api

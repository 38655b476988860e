// Request bodies as curl sends them, through the real server: a POST without a body (curl -X POST sends no
// Content-Length), a model with curl --data-binary's default form content type and beyond the HTTP library's
// 8 KiB form limit, a multipart upload (curl -F), and what a 400 says when a body is wrong or missing.
#include <gtest/gtest.h>

#include <string>

#include "api/model_store.h"
#include "models/linear/linear_model.h"
#include "tests/api/server_fixture.h"

namespace panelbass::api {
namespace {

using namespace api_testing;

// The raw bytes of a request as curl writes them (no Content-Length unless a body is given).
std::string curl_request(const std::string& method, const std::string& path, const std::string& content_type = "",
                         const std::string& body = "") {
  std::string request = method + " " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nUser-Agent: curl/7.88.1\r\nAccept: */*\r\n";
  if (!content_type.empty()) request += "Content-Type: " + content_type + "\r\n";
  if (!body.empty()) request += "Content-Length: " + std::to_string(body.size()) + "\r\n";
  return request + "Connection: close\r\n\r\n" + body;
}

// A model file of about 10 KB: a linear model with a long note in its meta, full of the "&" and "=" that a
// form body would be split at.
nlohmann::json large_model() {
  nlohmann::json model = models::linear_model_to_json(engine::testing::example_linear());
  std::string note;
  while (note.size() < 10000) note += "a=b&name=form&";
  model["meta"]["note"] = note;
  return model;
}

TEST_F(ServerTest, APostWithoutABodyActivatesAndAJobPostWithoutOneSaysABodyIsRequired) {
  start();
  const std::string id = upload(lq_gain_controller(0.5));
  // curl -X POST http://…/api/models/ID/activate: no body, no Content-Length.
  const Reply activated = raw_request(port_, curl_request("POST", "/api/models/" + id + "/activate"));
  ASSERT_EQ(activated.status, 200) << activated.text;
  EXPECT_EQ(activated.body["slot"], "feedforward");
  EXPECT_EQ(get("/api/status").body["active_models"]["feedforward"], id);

  // curl -X POST http://…/api/jobs: the body is required, and the 400 says so (not "HTTP 400").
  const Reply job = raw_request(port_, curl_request("POST", "/api/jobs"));
  EXPECT_EQ(job.status, 400) << job.text;
  EXPECT_EQ(job.body["error"]["code"], "bad_request") << job.text;
  const std::string message = error_message(job);
  EXPECT_NE(message.find("body: missing"), std::string::npos) << message;
  EXPECT_NE(message.find("POST /api/jobs"), std::string::npos) << message;
  EXPECT_NE(message.find("\"kind\""), std::string::npos) << message;
  // So does a body-less PATCH of the config.
  const Reply config = raw_request(port_, curl_request("PATCH", "/api/config"));
  EXPECT_EQ(config.status, 400) << config.text;
  EXPECT_NE(error_message(config).find("merge patch"), std::string::npos) << config.text;
  // curl -X DELETE sends no body either.
  const std::string other = upload(lq_gain_controller(0.25));
  EXPECT_EQ(raw_request(port_, curl_request("DELETE", "/api/models/" + other)).status, 204);
}

TEST_F(ServerTest, AModelUploadedWithCurlsDefaultFormContentTypeIsStored) {
  start();
  const nlohmann::json model = large_model();
  const std::string text = model.dump();
  ASSERT_GT(text.size(), 9000u);  // beyond cpp-httplib's 8192-byte limit for form bodies
  // curl --data-binary @model.json 'http://…/api/models?name=fir': application/x-www-form-urlencoded.
  const Reply stored = raw_request(
      port_, curl_request("POST", "/api/models?name=fir", "application/x-www-form-urlencoded", text));
  ASSERT_EQ(stored.status, 201) << stored.text;
  EXPECT_EQ(stored.body["id"], model_store_id(model));
  EXPECT_EQ(stored.body["name"], "fir");  // the body was not read as a form (its "=" and "&" as parameters)
  EXPECT_EQ(get("/api/models/" + model_store_id(model)).body["model"], model);
}

TEST_F(ServerTest, AModelUploadedAsTheOnePartOfAMultipartFormIsStoredAndTwoPartsAreRefused) {
  start();
  const nlohmann::json model = lq_gain_controller(0.5);
  // curl -F model=@lq.json http://…/api/models
  const httplib::MultipartFormDataItems one = {{"model", model.dump(), "lq.json", "application/json"}};
  const Reply stored = reply_of(client_->Post("/api/models", one));
  ASSERT_EQ(stored.status, 201) << stored.text;
  EXPECT_EQ(stored.body["id"], model_store_id(model));
  const httplib::MultipartFormDataItems two = {{"a", model.dump(), "a.json", "application/json"},
                                               {"b", model.dump(), "b.json", "application/json"}};
  const Reply refused = reply_of(client_->Post("/api/models", two));
  EXPECT_EQ(refused.status, 400) << refused.text;
  EXPECT_NE(error_message(refused).find("exactly one part"), std::string::npos) << refused.text;
}

TEST_F(ServerTest, ANumberBeyondADoublesRangeInAConfigPatchIsAMalformedRequest) {
  start();
  const nlohmann::json before = get("/api/config").body;
  const Reply r = patch("/api/config", R"({"band_pass":{"low_hz":1e999}})");
  EXPECT_EQ(r.status, 400) << r.text;
  EXPECT_EQ(r.body["error"]["code"], "bad_request") << r.text;
  EXPECT_NE(error_message(r).find("beyond a double's range"), std::string::npos) << r.text;
  EXPECT_EQ(get("/api/config").body, before);
}

}  // namespace
}  // namespace panelbass::api

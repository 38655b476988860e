// The checks before any route (issue #57, api/http/request_guard.h), through the real server: a page of another
// origin cannot change state (cross-site request forgery), a page reached through another name cannot use the
// server at all (DNS rebinding), a browser must label JSON as JSON, and OPTIONS is answered on purpose. The
// server's own page and curl keep working.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "models/linear/linear_model.h"
#include "tests/api/raw_http.h"
#include "tests/api/server_fixture.h"

namespace panelbass::api {
namespace {

using namespace api_testing;

const std::string kEvil = "http://evil.example";
const std::string kJob = R"({"kind":"excite","params":{"samples":1000}})";

TEST_F(ServerTest, AStateChangeFromAForeignOriginIsRefusedAndChangesNothing) {
  start();
  const std::string controller = upload(lq_gain_controller(0.5));
  // The "simple" requests a page can send anywhere without a preflight: text/plain, its Origin attached.
  const RawReply job = send_raw(port_, http_request("POST", "/api/jobs", port_, {{"Origin", kEvil}, {"Content-Type", "text/plain"}}, kJob));
  EXPECT_EQ(job.status, 403) << job.text;
  EXPECT_EQ(job.body["error"]["code"], "cross_origin") << job.text;
  EXPECT_NE(job.body["error"]["message"].get<std::string>().find(kEvil), std::string::npos) << job.text;
  const RawReply model = send_raw(port_, http_request("POST", "/api/models?name=x", port_, {{"Origin", kEvil}, {"Content-Type", "text/plain"}},
                                                      models::linear_model_to_json(engine::testing::example_linear()).dump()));
  EXPECT_EQ(model.status, 403) << model.text;
  const RawReply activate = send_raw(port_, http_request("POST", "/api/models/" + controller + "/activate", port_, {{"Origin", kEvil}}));
  EXPECT_EQ(activate.status, 403) << activate.text;
  const RawReply remove = send_raw(port_, http_request("DELETE", "/api/models/" + controller, port_, {{"Origin", kEvil}}));
  EXPECT_EQ(remove.status, 403) << remove.text;
  const RawReply config = send_raw(port_, http_request("PATCH", "/api/config", port_, {{"Origin", kEvil}, {"Content-Type", "application/json"}},
                                                       R"({"band_pass":{"low_hz":31}})"));
  EXPECT_EQ(config.status, 403) << config.text;
  // A browser that sends no Origin still says where the request comes from.
  const RawReply site = send_raw(port_, http_request("POST", "/api/jobs", port_, {{"Sec-Fetch-Site", "cross-site"}, {"Content-Type", "application/json"}}, kJob));
  EXPECT_EQ(site.status, 403) << site.text;
  // Nothing changed, and no answer carried CORS headers for the foreign page.
  EXPECT_EQ(get("/api/jobs").body["total"], 0);
  EXPECT_EQ(get("/api/models").body["models"].size(), 1u);
  EXPECT_EQ(get("/api/status").body["active_models"]["feedforward"], nullptr);
  EXPECT_EQ(get("/api/config").body["band_pass"]["low_hz"], 20.0);
  for (const RawReply& r : {job, model, activate, remove, config, site}) {
    EXPECT_EQ(r.header("Access-Control-Allow-Origin"), "") << r.head;
  }
}

TEST_F(ServerTest, TheServersOwnPageAnAllowedOriginAndCurlMayChangeState) {
  ServerOptions o = options(dir_ / "store");
  o.allowed_origins = {"https://Panel.Example"};
  start(std::move(o));
  // The page the server served (Origin = the address it was loaded from), as web/api.js sends it.
  const std::string own = "http://127.0.0.1:" + std::to_string(port_);
  const RawReply page = send_raw(port_, http_request("POST", "/api/jobs", port_,
                                                     {{"Origin", own}, {"Sec-Fetch-Site", "same-origin"}, {"Content-Type", "application/json"}}, kJob));
  EXPECT_EQ(page.status, 202) << page.text;
  EXPECT_EQ(page.header("Access-Control-Allow-Origin"), "") << page.head;  // same origin: nothing to allow
  // An origin on the allow list (compared as browsers write it, lower case) may, and may read the answer.
  const RawReply allowed = send_raw(port_, http_request("POST", "/api/jobs", port_,
                                                        {{"Origin", "https://panel.example"}, {"Content-Type", "application/json"}}, kJob));
  EXPECT_EQ(allowed.status, 202) << allowed.text;
  EXPECT_EQ(allowed.header("Access-Control-Allow-Origin"), "https://panel.example") << allowed.head;
  // curl: no Origin, and -d's default form label on a JSON body.
  const RawReply curl = send_raw(port_, http_request("POST", "/api/jobs", port_, {{"Content-Type", "application/x-www-form-urlencoded"}}, kJob));
  EXPECT_EQ(curl.status, 202) << curl.text;
  // Reading needs no origin check (a foreign page cannot read the answer without CORS headers).
  const RawReply read = send_raw(port_, http_request("GET", "/api/config", port_, {{"Origin", kEvil}}));
  EXPECT_EQ(read.status, 200) << read.text;
  EXPECT_EQ(read.header("Access-Control-Allow-Origin"), "") << read.head;
}

TEST_F(ServerTest, ABrowsersJsonRouteBodyMustBeLabelledJson) {
  start();
  const std::string own = "http://127.0.0.1:" + std::to_string(port_);
  for (const char* type : {"text/plain", "application/x-www-form-urlencoded", "multipart/form-data; boundary=x"}) {
    const RawReply r = send_raw(port_, http_request("POST", "/api/jobs", port_, {{"Origin", own}, {"Content-Type", type}}, kJob));
    EXPECT_EQ(r.status, 415) << type << ": " << r.text;
    EXPECT_EQ(r.body["error"]["code"], "unsupported_media_type") << r.text;
    EXPECT_NE(r.body["error"]["message"].get<std::string>().find("application/json"), std::string::npos) << r.text;
  }
  // text/plain is nobody's JSON label, curl's included.
  const RawReply plain = send_raw(port_, http_request("PUT", "/api/config", port_, {{"Content-Type", "text/plain"}}, "{}"));
  EXPECT_EQ(plain.status, 415) << plain.text;
  // A merge patch's own type is JSON.
  const RawReply patch = send_raw(port_, http_request("PATCH", "/api/config", port_, {{"Content-Type", "application/merge-patch+json"}},
                                                      R"({"band_pass":{"low_hz":30}})"));
  EXPECT_EQ(patch.status, 200) << patch.text;
  EXPECT_EQ(get("/api/jobs").body["total"], 0);
}

TEST_F(ServerTest, OptionsIsAPreflightForAnAllowedOriginAndRefusedForAnyOther) {
  ServerOptions o = options(dir_ / "store");
  o.allowed_origins = {"https://panel.example"};
  start(std::move(o));
  const RawReply allowed = send_raw(port_, http_request("OPTIONS", "/api/jobs", port_,
                                                        {{"Origin", "https://panel.example"}, {"Access-Control-Request-Method", "POST"}}));
  EXPECT_EQ(allowed.status, 204) << allowed.text;
  EXPECT_EQ(allowed.header("Access-Control-Allow-Origin"), "https://panel.example") << allowed.head;
  EXPECT_NE(allowed.header("Access-Control-Allow-Methods").find("POST"), std::string::npos) << allowed.head;
  EXPECT_NE(allowed.header("Access-Control-Allow-Headers").find("Content-Type"), std::string::npos) << allowed.head;
  const RawReply foreign = send_raw(port_, http_request("OPTIONS", "/api/jobs", port_,
                                                        {{"Origin", kEvil}, {"Access-Control-Request-Method", "POST"}}));
  EXPECT_EQ(foreign.status, 403) << foreign.text;
  EXPECT_EQ(foreign.header("Access-Control-Allow-Origin"), "") << foreign.head;
  EXPECT_EQ(foreign.body["error"]["code"], "cross_origin") << foreign.text;
  const RawReply plain = send_raw(port_, http_request("OPTIONS", "/api/models", port_));
  EXPECT_EQ(plain.status, 204) << plain.text;
  EXPECT_NE(plain.header("Allow").find("DELETE"), std::string::npos) << plain.head;
}

TEST_F(ServerTest, AForeignHostIsRefusedBeforeAnyRouteRuns) {
  ServerOptions o = options(dir_ / "store");
  o.allowed_hosts = {"panel.example"};
  start(std::move(o));
  const std::string port = std::to_string(port_);
  // A page of evil.example whose name now resolves to 127.0.0.1 (DNS rebinding) is same-origin to itself.
  const std::string evil_host = "evil.example:" + port;
  const RawReply read = send_raw(port_, http_request("GET", "/api/config", port_, {{"Host", evil_host}}));
  EXPECT_EQ(read.status, 421) << read.text;
  EXPECT_EQ(read.body["error"]["code"], "misdirected") << read.text;
  EXPECT_NE(read.body["error"]["message"].get<std::string>().find(evil_host), std::string::npos) << read.text;
  const RawReply write = send_raw(port_, http_request("PATCH", "/api/config", port_,
                                                      {{"Host", evil_host}, {"Origin", "http://" + evil_host}, {"Content-Type", "application/json"}},
                                                      R"({"band_pass":{"low_hz":31}})"));
  EXPECT_EQ(write.status, 421) << write.text;
  EXPECT_EQ(send_raw(port_, http_request("GET", "/", port_, {{"Host", evil_host}})).status, 421);
  EXPECT_EQ(send_raw(port_, http_request("GET", "/api/health", port_, {{"Host", "127.0.0.1.evil.example:" + port}})).status, 421);
  EXPECT_EQ(get("/api/config").body["band_pass"]["low_hz"], 20.0);
  // Its own names: loopback (any spelling of it) and the names it was told.
  for (const std::string& host : std::vector<std::string>{"127.0.0.1:" + port, "localhost:" + port, "LOCALHOST", "[::1]:" + port, "panel.example:" + port}) {
    EXPECT_EQ(send_raw(port_, http_request("GET", "/api/health", port_, {{"Host", host}})).status, 200) << host;
  }
}

}  // namespace
}  // namespace panelbass::api

// The real server on a loopback port, exercised route by route with cpp-httplib's client, bad input
// included (api/ROUTES.md is the specification).
#include "api/server.h"

#include <gtest/gtest.h>

#include <sys/resource.h>

#include <chrono>
#include <csignal>
#include <functional>
#include <fstream>
#include <mutex>
#include <regex>
#include <set>
#include <thread>

#include "api/jobs/job_kinds.h"
#include "models/linear/linear_model.h"
#include "models/plant/plant_config.h"
#include "tests/api/server_fixture.h"

namespace panelbass::api {
namespace {

using namespace std::chrono_literals;
using namespace api_testing;
using engine::testing::example_linear;
using engine::testing::resonant_linear;

TEST_F(ServerTest, HealthStatusAndMetricsDescribeARunningEngine) {
  start();
  const Reply health = get("/api/health");
  ASSERT_EQ(health.status, 200);
  EXPECT_EQ(health.body["status"], "ok");

  std::this_thread::sleep_for(200ms);  // a few blocks of 64 samples at 3 kHz (21 ms each)
  const Reply status = get("/api/status");
  ASSERT_EQ(status.status, 200) << status.text;
  EXPECT_EQ(status.body["engine"]["state"], "running");
  EXPECT_EQ(status.body["engine"]["backend"], "virtual");
  EXPECT_EQ(status.body["engine"]["fs"], 3000.0);
  EXPECT_GT(status.body["metrics"]["blocks"].get<double>(), 2.0);
  EXPECT_TRUE(status.body["active_models"]["feedforward"].is_null());

  const Reply metrics = get("/metrics");
  ASSERT_EQ(metrics.status, 200);
  // Prometheus text: the block counter is at least what the status saw, and the earlier 200 is counted.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(metrics.text, m, std::regex(R"(\npanelbass_blocks_total (\d+)\n)"))) << metrics.text;
  EXPECT_GE(std::stod(m[1]), status.body["metrics"]["blocks"].get<double>());
  ASSERT_TRUE(std::regex_search(metrics.text, m, std::regex(R"(panelbass_http_requests_total\{code="200"\} (\d+))")));
  // At least the health check's (the logger counts a response after sending it, so the status request
  // just before may not be counted yet).
  EXPECT_GE(std::stoi(m[1]), 1);
  EXPECT_NE(metrics.text.find("# TYPE panelbass_xruns_total counter"), std::string::npos);
}

TEST_F(ServerTest, TheOpenApiDocumentNamesExactlyTheRoutesTheServerHas) {
  start();
  const Reply doc = get("/api/openapi.json");
  ASSERT_EQ(doc.status, 200);
  std::set<std::pair<std::string, std::string>> documented, served;
  for (const auto& [path, item] : doc.body["paths"].items()) {
    for (const auto& [method, operation] : item.items()) documented.insert({method, path});
  }
  for (const Route& r : api_routes()) served.insert({r.method, r.path});
  EXPECT_EQ(documented, served);
  // and exactly the job kinds the server runs
  EXPECT_EQ(doc.body["components"]["schemas"]["JobRequest"]["properties"]["kind"]["enum"], nlohmann::json(job_kinds()));
  // Every served route answers something other than "no such route" (path ids filled in).
  for (const Route& r : api_routes()) {
    const std::string path = std::regex_replace(r.path, std::regex(R"(\{id\})"), "unknown-id");
    httplib::Request req;
    req.method = r.method == "get" ? "GET" : r.method == "post" ? "POST" : r.method == "put" ? "PUT"
                 : r.method == "patch" ? "PATCH" : "DELETE";
    req.path = path;
    if (r.path == "/api/jobs/{id}/events") continue;  // a stream; covered by its own test
    const httplib::Result res = client_->send(req);
    ASSERT_TRUE(res) << path;
    const nlohmann::json body = nlohmann::json::parse(res->body, nullptr, false);
    const std::string message = body.is_object() && body.contains("error") ? body["error"].value("message", "") : "";
    EXPECT_EQ(message.find("no such route"), std::string::npos) << r.method << " " << path;
  }
  // An unknown route is a 404 with the error object.
  const Reply none = get("/api/nothing");
  EXPECT_EQ(none.status, 404);
  EXPECT_EQ(none.body["error"]["code"], "not_found");
}

TEST_F(ServerTest, ConfigChangesAreValidatedThenAppliedWithoutStoppingTheEngine) {
  start();
  const Reply before = get("/api/config");
  ASSERT_EQ(before.status, 200);
  EXPECT_EQ(before.body["band_pass"]["low_hz"], 20.0);
  EXPECT_TRUE(before.body["feedforward"]["model"].is_null());

  const Reply changed = patch("/api/config", R"({"band_pass":{"low_hz":30},"limiter":{"knee":0.7}})");
  ASSERT_EQ(changed.status, 200) << changed.text;
  EXPECT_EQ(changed.body["change"]["kind"], "rebuild with crossfade");
  EXPECT_EQ(changed.body["config"]["band_pass"]["low_hz"], 30.0);
  EXPECT_EQ(get("/api/config").body["limiter"]["knee"], 0.7);

  // Bad changes leave everything as it was, and say what is wrong.
  const Reply unknown = patch("/api/config", R"({"band_pass":{"lowhz":30}})");
  EXPECT_EQ(unknown.status, 400);
  EXPECT_NE(error_message(unknown).find("band_pass.lowhz"), std::string::npos) << unknown.text;
  const Reply wrong_type = patch("/api/config", R"({"crossfade_ms":"long"})");
  EXPECT_EQ(wrong_type.status, 400);
  EXPECT_NE(error_message(wrong_type).find("crossfade_ms"), std::string::npos) << wrong_type.text;
  const Reply above_nyquist = patch("/api/config", R"({"band_pass":{"high_hz":2000}})");
  EXPECT_EQ(above_nyquist.status, 400);
  EXPECT_NE(error_message(above_nyquist).find("high_hz"), std::string::npos) << above_nyquist.text;
  const Reply restart = patch("/api/config", R"({"block":128})");
  EXPECT_EQ(restart.status, 409);
  EXPECT_NE(error_message(restart).find("block"), std::string::npos);
  const Reply malformed = patch("/api/config", R"({"band_pass":)");
  EXPECT_EQ(malformed.status, 400);
  EXPECT_NE(error_message(malformed).find("malformed JSON"), std::string::npos);
  const Reply no_model = patch("/api/config", R"({"feedforward":{"model":"m000000000000"}})");
  EXPECT_EQ(no_model.status, 400);
  EXPECT_NE(error_message(no_model).find("feedforward.model"), std::string::npos);
  EXPECT_EQ(get("/api/config").body, changed.body["config"]);

  // PUT with the whole object.
  nlohmann::json whole = changed.body["config"];
  whole["band_pass"]["bypass"] = true;
  const Reply replaced = put("/api/config", whole);
  ASSERT_EQ(replaced.status, 200) << replaced.text;
  EXPECT_EQ(replaced.body["change"]["kind"], "in place");
  EXPECT_EQ(get("/api/status").body["engine"]["state"], "running");
}

TEST_F(ServerTest, ModelsAreValidatedStoredListedActivatedAndDeleted) {
  start();
  const nlohmann::json model = models::linear_model_to_json(example_linear());
  const Reply first = post("/api/models?name=example", model);
  ASSERT_EQ(first.status, 201) << first.text;
  const std::string plant = first.body["id"];
  EXPECT_EQ(plant, model_store_id(model));
  EXPECT_EQ(first.body["kind"], "linear");
  EXPECT_EQ(first.body["name"], "example");
  EXPECT_EQ(first.body["slots"], nlohmann::json::array());  // a plant model runs in no slot
  const Reply again = post("/api/models", model);
  EXPECT_EQ(again.status, 200);
  EXPECT_EQ(again.body["id"], plant);
  EXPECT_EQ(get("/api/models/" + plant).body["model"], model);

  const nlohmann::json controller = lq_gain_controller(0.5);
  const Reply stored = post("/api/models", controller);
  ASSERT_EQ(stored.status, 201) << stored.text;
  const std::string id = stored.body["id"];
  EXPECT_EQ(stored.body["slots"], nlohmann::json::array({"feedforward"}));
  const Reply list = get("/api/models");
  ASSERT_EQ(list.body["models"].size(), 2u);

  const std::uint64_t swaps_before = get("/api/status").body["metrics"]["swaps"];
  const Reply activated = post("/api/models/" + id + "/activate", std::string());
  ASSERT_EQ(activated.status, 200) << activated.text;
  EXPECT_EQ(activated.body["slot"], "feedforward");
  EXPECT_EQ(get("/api/status").body["active_models"]["feedforward"], id);
  EXPECT_EQ(get("/api/config").body["feedforward"]["model"], id);
  EXPECT_EQ(get("/api/models/" + id).body["active_in"], nlohmann::json::array({"feedforward"}));
  // The slot takes the new stage over at a block boundary.
  const nlohmann::json swapped =
      wait_status([&](const nlohmann::json& s) { return s["metrics"]["swaps"].get<std::uint64_t>() > swaps_before; });
  EXPECT_GT(swapped["metrics"]["swaps"].get<std::uint64_t>(), swaps_before);

  const Reply busy = del("/api/models/" + id);
  EXPECT_EQ(busy.status, 409);
  const Reply bad_slot = post("/api/models/" + id + "/activate", nlohmann::json{{"slot", "middle"}});
  EXPECT_EQ(bad_slot.status, 400);
  const Reply unknown_field = post("/api/models/" + id + "/activate", nlohmann::json{{"slto", "feedback"}});
  EXPECT_EQ(unknown_field.status, 400);
  EXPECT_NE(error_message(unknown_field).find("slto"), std::string::npos);

  // A second controller replaces it; then the first can go.
  const std::string other = upload(lq_gain_controller(0.25));
  ASSERT_EQ(post("/api/models/" + other + "/activate", nlohmann::json::object()).status, 200);
  EXPECT_EQ(del("/api/models/" + id).status, 204);
  EXPECT_EQ(get("/api/models/" + id).status, 404);
  EXPECT_EQ(del("/api/models/" + plant).status, 204);
  EXPECT_EQ(get("/api/models").body["models"].size(), 1u);
}

TEST_F(ServerTest, BadModelsAndBadIdsAreRefusedWithTheReason) {
  ServerOptions o = options(dir_ / "store");
  o.body_limit = 64 * 1024;
  start(std::move(o));
  // Unstable: poles at |z| = 1.05.
  const Reply unstable =
      post("/api/models", models::linear_model_to_json(resonant_linear(1.05, 0.3, Eigen::Vector2d(0.1, 0.0), 1)));
  EXPECT_EQ(unstable.status, 422) << unstable.text;
  EXPECT_EQ(unstable.body["error"]["code"], "invalid_model");
  // A non-finite coefficient (1e999 parses as infinity).
  std::string text = models::linear_model_to_json(example_linear()).dump();
  const std::size_t b = text.find("0.03");
  ASSERT_NE(b, std::string::npos);
  text.replace(b, 4, "1e999");
  const Reply infinite = post("/api/models", text);
  EXPECT_EQ(infinite.status, 422) << infinite.text;
  // Not a model at all, malformed JSON, wrong kind.
  EXPECT_EQ(post("/api/models", std::string(R"({"kind":"linear"})")).status, 400);
  EXPECT_EQ(post("/api/models", std::string(R"({"kind":"teapot"})")).status, 400);
  EXPECT_EQ(post("/api/models", std::string("{\"kind\":")).status, 400);
  EXPECT_EQ(post("/api/models", std::string("[1,2]")).status, 400);
  // At another rate than the engine.
  models::LinearModel fast = example_linear();
  fast.fs = 48000.0;
  const Reply fast_reply = post("/api/models", models::linear_model_to_json(fast));
  EXPECT_EQ(fast_reply.status, 422);
  // Numbers as people write them (not "48000.000000 Hz").
  EXPECT_NE(error_message(fast_reply).find("model.fs: the model runs at 48000 Hz, the engine at 3000 Hz"), std::string::npos)
      << fast_reply.text;
  // A plant description sent as a model: what it is and where it belongs.
  const Reply plant = post("/api/models", models::plant_to_json(models::plant_preset("panel-exciter")));
  EXPECT_EQ(plant.status, 400);
  EXPECT_NE(error_message(plant).find("this is a plant description"), std::string::npos) << plant.text;
  EXPECT_NE(error_message(plant).find("--plant"), std::string::npos) << plant.text;
  // Oversized body: the message names the limit.
  const Reply big = post("/api/models", std::string(100 * 1024, ' '));
  EXPECT_EQ(big.status, 413);
  EXPECT_EQ(big.body["error"]["code"], "too_large");
  EXPECT_NE(error_message(big).find("size limit of 64 KiB"), std::string::npos) << big.text;
  // Unknown and path-traversal ids.
  EXPECT_EQ(get("/api/models/m123456789abc").status, 404);
  EXPECT_EQ(get("/api/jobs/j999").status, 404);
  const Reply traversal = get("/api/models/%2E%2E");
  EXPECT_EQ(traversal.status, 400) << traversal.text;
  EXPECT_EQ(del("/api/models/a.b").status, 400);
  EXPECT_EQ(get("/api/models").body["models"].size(), 0u);
}

TEST_F(ServerTest, AnIdentificationJobRunsReportsProgressAndADesignOnItsModelIsActivated) {
  start();
  const Reply submitted = post("/api/jobs", nlohmann::json{
      {"kind", "identify-linear"},
      {"params", {{"excite", {{"samples", 3000}, {"seed", 3}}}, {"method", "oe"}, {"order", 4}}}});
  ASSERT_EQ(submitted.status, 202) << submitted.text;
  const std::string id = submitted.body["id"];

  // The event stream, read to its end: progress events, then the final state.
  std::string stream;
  httplib::Client sse("127.0.0.1", port_);
  sse.set_read_timeout(120, 0);
  const httplib::Result r = sse.Get(("/api/jobs/" + id + "/events").c_str(),
                                    [&stream](const char* data, std::size_t n) {
                                      stream.append(data, n);
                                      return true;
                                    });
  ASSERT_TRUE(r);
  EXPECT_EQ(r->get_header_value("Content-Type"), "text/event-stream");
  EXPECT_NE(stream.find("event: progress"), std::string::npos) << stream;
  EXPECT_NE(stream.find("event: state\ndata: {\"state\":\"succeeded\""), std::string::npos) << stream;

  const nlohmann::json job = wait_job(id);
  ASSERT_EQ(job["state"], "succeeded") << job.dump();
  const std::string model_id = job["result"]["model_id"];
  EXPECT_FALSE(job.contains("activated")) << job.dump();
  EXPECT_EQ(get("/api/models/" + model_id).body["source"], id);
  // The LQ feedforward designed on it is a controller: activated when its job succeeds.
  const Reply design = post("/api/jobs", nlohmann::json{{"kind", "design-lq"}, {"params", {{"plant_model", model_id}}},
                                                        {"activate", true}});
  ASSERT_EQ(design.status, 202) << design.text;
  const nlohmann::json designed = wait_job(design.body["id"]);
  ASSERT_EQ(designed["state"], "succeeded") << designed.dump();
  const std::string controller = designed["result"]["model_id"];
  EXPECT_EQ(designed["activated"], (nlohmann::json{{"slot", "feedforward"}, {"id", controller}}));
  EXPECT_EQ(get("/api/status").body["active_models"]["feedforward"], controller);
  const nlohmann::json& fit = job["result"]["plots"]["fit"];
  EXPECT_EQ(fit["measured"].size(), fit["simulated"].size());
  EXPECT_GT(fit["measured"].size(), 100u);
  // The list is newest first: the design, then the identification.
  const nlohmann::json jobs = get("/api/jobs").body["jobs"];
  ASSERT_EQ(jobs.size(), 2u) << jobs.dump();
  EXPECT_EQ(jobs[0]["id"], design.body["id"]);
  EXPECT_EQ(jobs[1]["id"], id);
}

TEST_F(ServerTest, JobsCanBeCancelledMidwayAndBadJobRequestsAreRefused) {
  start();
  const Reply submitted = post("/api/jobs", nlohmann::json{
      {"kind", "identify-narx"},
      {"params", {{"excite", {{"samples", 4000}, {"seed", 2}}}, {"hidden", {10}}, {"max_iterations", 5000}}}});
  ASSERT_EQ(submitted.status, 202) << submitted.text;
  const std::string id = submitted.body["id"];
  const auto until = std::chrono::steady_clock::now() + 60s;
  while (get("/api/jobs/" + id).body.value("progress", 0.0) <= 0.0 && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(20ms);
  }
  const Reply cancel = del("/api/jobs/" + id);
  ASSERT_EQ(cancel.status, 200) << cancel.text;
  const nlohmann::json job = wait_job(id, 60s);
  EXPECT_EQ(job["state"], "cancelled") << job.dump();
  EXPECT_TRUE(job["result"].is_null());
  EXPECT_EQ(del("/api/jobs/" + id).status, 409);

  const Reply unknown_kind = post("/api/jobs", nlohmann::json{{"kind", "teleport"}});
  EXPECT_EQ(unknown_kind.status, 400);
  EXPECT_NE(error_message(unknown_kind).find("teleport"), std::string::npos);
  const Reply bad_param = post("/api/jobs", nlohmann::json{{"kind", "identify-linear"}, {"params", {{"order", "eight"}}}});
  EXPECT_EQ(bad_param.status, 400);
  EXPECT_NE(error_message(bad_param).find("order"), std::string::npos) << bad_param.text;
  const Reply unknown_param = post("/api/jobs", nlohmann::json{{"kind", "excite"}, {"params", {{"sampels", 10}}}});
  EXPECT_EQ(unknown_param.status, 400);
  EXPECT_NE(error_message(unknown_param).find("sampels"), std::string::npos);
  const Reply no_plant = post("/api/jobs", nlohmann::json{{"kind", "design-lq"}, {"params", nlohmann::json::object()}});
  EXPECT_EQ(no_plant.status, 400);
  EXPECT_NE(error_message(no_plant).find("plant_model"), std::string::npos);
  const Reply extra = post("/api/jobs", nlohmann::json{{"kind", "excite"}, {"priority", 1}});
  EXPECT_EQ(extra.status, 400);
  EXPECT_NE(error_message(extra).find("priority"), std::string::npos);
}

TEST_F(ServerTest, TheStoreSurvivesARestartWithACorruptFileInIt) {
  const std::filesystem::path store = dir_ / "store";
  std::string id;
  {
    start(options(store));
    id = upload(models::linear_model_to_json(example_linear()));
    ASSERT_FALSE(id.empty());
    server_->stop();
  }
  server_.reset();
  std::ofstream(store / "models" / "m0123456789ab.json") << "{\"format\":\"panelbass.stored-model/1\",\"id\":";
  std::ofstream(store / "models" / "foreign.json") << R"({"format":"something-else/2"})";
  start(options(store));
  const Reply list = get("/api/models");
  ASSERT_EQ(list.status, 200);
  ASSERT_EQ(list.body["models"].size(), 1u) << list.text;
  EXPECT_EQ(list.body["models"][0]["id"], id);
  const std::vector<std::string> lines = log_lines();
  const auto names = [&lines](const std::string& file) {
    for (const std::string& l : lines) {
      if (l.find(file) != std::string::npos) return true;
    }
    return false;
  };
  EXPECT_TRUE(names("m0123456789ab.json"));
  EXPECT_TRUE(names("foreign.json"));
}

TEST_F(ServerTest, ATokenGuardsTheApiAndIsRequiredBeyondLoopback) {
  ServerOptions open = options(dir_ / "a");
  open.bind = "0.0.0.0";
  EXPECT_THROW(Server{open}, std::invalid_argument);

  ServerOptions guarded = options(dir_ / "b");
  guarded.token = "s3cret";
  start(std::move(guarded));
  EXPECT_EQ(get("/api/status").status, 401);
  EXPECT_EQ(get("/metrics").status, 401);
  client_->set_bearer_token_auth("s3cret");
  EXPECT_EQ(get("/api/status").status, 200);
  client_->set_bearer_token_auth("wrong");
  EXPECT_EQ(get("/api/status").status, 401);
}

TEST_F(ServerTest, ASaturatingControllerTripsTheChainWhichRecoversAndTheDriveStaysBounded) {
  start();
  // A gain of 6 to 8 (u* = u + 7·u(k−1)) behind the band-pass pins the drive at the rails on the engine's
  // noise program; with max_pinned_ms = 1 (3 samples) the limiter trips at once.
  ASSERT_EQ(patch("/api/config", R"({"limiter":{"max_pinned_ms":1}})").status, 200);
  const std::string id = upload(lq_gain_controller(7.0));
  ASSERT_EQ(post("/api/models/" + id + "/activate", nlohmann::json::object()).status, 200);
  const auto wait_for = [this](const std::function<bool(const nlohmann::json&)>& condition) { return wait_status(condition); };
  const nlohmann::json tripped = wait_for([](const nlohmann::json& s) { return s["metrics"]["in_fault"] == true; });
  ASSERT_EQ(tripped["metrics"]["in_fault"], true) << tripped.dump();
  EXPECT_EQ(tripped["metrics"]["last_fault"], "drive pinned at the rails");
  EXPECT_GE(tripped["metrics"]["faults"].get<int>(), 1);
  // The housekeeping brings it back after its hold time (and it trips again: the gain is still there).
  const nlohmann::json recovered =
      wait_for([](const nlohmann::json& s) { return s["engine"]["recoveries"].get<int>() >= 1; });
  ASSERT_GE(recovered["engine"]["recoveries"].get<int>(), 1) << recovered.dump();
  // The controller removed, the next recovery holds.
  ASSERT_EQ(patch("/api/config", R"({"feedforward":{"model":null}})").status, 200);
  const nlohmann::json clear = wait_for([](const nlohmann::json& s) { return s["metrics"]["in_fault"] == false; });
  EXPECT_EQ(clear["metrics"]["in_fault"], false) << clear.dump();
  EXPECT_EQ(clear["engine"]["state"], "running");
  EXPECT_LE(clear["metrics"]["peak_drive"].get<double>(), 1.0);
  EXPECT_GT(clear["metrics"]["peak_drive"].get<double>(), 0.5);  // the gain did reach the limiter
  const std::string metrics = get("/metrics").text;
  EXPECT_NE(metrics.find("panelbass_faults_total"), std::string::npos);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(metrics, m, std::regex(R"(\npanelbass_peak_drive ([0-9.e+-]+)\n)")));
  EXPECT_LE(std::stod(m[1]), 1.0);
}

TEST_F(ServerTest, AStoreThatCannotBeWrittenGivesAClearErrorAndKeepsWhatItHad) {
  start();
  const std::string kept = upload(models::linear_model_to_json(example_linear()));
  // A file size limit of 64 bytes stands in for a full disk: the write fails (EFBIG, SIGXFSZ ignored).
  struct rlimit old {};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto previous = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit small = old;
  small.rlim_cur = 64;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  const Reply refused = post("/api/models", models::linear_model_to_json(resonant_linear(0.9, 0.3, Eigen::Vector2d(0.1, 0.05), 1)));
  setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, previous);
  EXPECT_EQ(refused.status, 507) << refused.text;
  EXPECT_EQ(refused.body["error"]["code"], "storage");
  EXPECT_NE(error_message(refused).find("File too large"), std::string::npos) << refused.text;
  const Reply list = get("/api/models");
  ASSERT_EQ(list.body["models"].size(), 1u);
  EXPECT_EQ(list.body["models"][0]["id"], kept);
  for (const auto& entry : std::filesystem::directory_iterator(dir_ / "store" / "models")) {
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << "left-over " << entry.path();
  }
}

TEST_F(ServerTest, AnOldJobsResultComesFromTheStoreAfterMemoryDroppedIt) {
  start();
  std::vector<std::string> ids;
  for (std::size_t k = 0; k < JobQueue::kResultsKept + 2; ++k) {
    const Reply r = post("/api/jobs", nlohmann::json{{"kind", "excite"},
                                                     {"params", {{"samples", 200}, {"validation_samples", 200}, {"seed", k + 1}}}});
    ASSERT_EQ(r.status, 202) << r.text;
    ids.push_back(r.body["id"]);
    // The queue takes at most ServerOptions::max_queued_jobs waiting jobs: let it drain before it is full.
    if (ids.size() % 16 == 0) ASSERT_EQ(wait_job(ids.back())["state"], "succeeded");
  }
  for (const std::string& id : ids) ASSERT_EQ(wait_job(id)["state"], "succeeded");
  ASSERT_TRUE(server_->jobs().get(ids.front())->result_dropped);
  const Reply oldest = get("/api/jobs/" + ids.front());
  ASSERT_EQ(oldest.status, 200);
  // Its record is kept once in the record store (named there), not in the job's file.
  ASSERT_TRUE(oldest.body["result"]["record_id"].is_string()) << oldest.text.substr(0, 300);
  const Reply kept = get("/api/records/" + oldest.body["result"]["record_id"].get<std::string>());
  ASSERT_EQ(kept.status, 200) << kept.text.substr(0, 300);
  EXPECT_EQ(kept.body["samples"], 400u);
  EXPECT_EQ(kept.body["name"], "excitation of " + ids.front());
  // It can still be used as the record of an identification.
  const Reply identify = post("/api/jobs", nlohmann::json{{"kind", "identify-linear"},
                                                          {"params", {{"record", ids.front()}, {"order", 2}}}});
  ASSERT_EQ(identify.status, 202) << identify.text;
  const nlohmann::json done = wait_job(identify.body["id"]);
  EXPECT_EQ(done["state"], "succeeded");
}

}  // namespace
}  // namespace panelbass::api

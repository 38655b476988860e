// GET /metrics checked by Prometheus's own linter, `promtool check metrics` (Debian's prometheus package,
// which scripts/bootstrap.sh installs): the real server's exposition after requests of several statuses, and
// the exposition with a sound card's families as well. Skipped, saying why, only where promtool is absent.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "api/prometheus.h"
#include "tests/api/server_fixture.h"
#include "tests/support/cli_runner.h"

namespace panelbass::api {
namespace {

using namespace api_testing;

// True when promtool is on the PATH.
bool have_promtool() { return std::system("command -v promtool >/dev/null 2>&1") == 0; }

// Runs `promtool check metrics` on `text` (through files in `dir`); returns its exit status and what it printed.
std::pair<int, std::string> promtool_check(const std::string& text, const std::filesystem::path& dir) {
  const std::filesystem::path in = dir / "metrics.txt", out = dir / "promtool.txt";
  std::ofstream(in) << text;
  const std::string command = "promtool check metrics < " + testing_support::quoted(in) + " > " +
                              testing_support::quoted(out) + " 2>&1";
  const int raw = std::system(command.c_str());
  std::stringstream printed;
  printed << std::ifstream(out).rdbuf();
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, printed.str()};
}

#define SKIP_WITHOUT_PROMTOOL()                                                                          \
  if (!have_promtool()) {                                                                                \
    GTEST_SKIP() << "promtool is not installed (Debian package prometheus; scripts/bootstrap.sh installs " \
                    "it): /metrics was not checked";                                                     \
  }

TEST_F(ServerTest, TheRealServersMetricsPassPromtoolCheckMetrics) {
  SKIP_WITHOUT_PROMTOOL();
  start();
  // Responses of several statuses and a job, so that every labelled family has samples.
  EXPECT_EQ(get("/api/status").status, 200);
  EXPECT_EQ(get("/api/nothing").status, 404);
  EXPECT_EQ(post("/api/jobs", nlohmann::json{{"kind", "teleport"}}).status, 400);
  const Reply metrics = get("/metrics");
  ASSERT_EQ(metrics.status, 200);
  ASSERT_NE(metrics.text.find("panelbass_block_seconds_max"), std::string::npos) << metrics.text;
  const auto [status, printed] = promtool_check(metrics.text, dir_);
  EXPECT_EQ(status, 0) << printed << "\n--- the exposition:\n" << metrics.text;
  EXPECT_EQ(printed, "") << metrics.text;
}

TEST_F(ServerTest, TheMetricsOfASoundCardPassPromtoolCheckMetrics) {
  SKIP_WITHOUT_PROMTOOL();
  engine::MetricsSnapshot engine;
  engine.blocks = 10;
  engine.samples = 640;
  engine.limited_samples = 3;
  engine.peak_demand = 1.2;
  ServiceCounts service;
  service.jobs_by_state = {{"queued", 1}, {"running", 0}, {"succeeded", 2}, {"failed", 0}, {"cancelled", 0}};
  service.responses_by_status = {{200, 5}, {400, 1}};
  service.models_stored = 2;
  service.device = engine::AlsaStatus{};
  service.device->opens = 2;
  const std::string text = prometheus_text(engine, service);
  ASSERT_NE(text.find("panelbass_device_reopens_total 1"), std::string::npos) << text;
  const auto [status, printed] = promtool_check(text, dir_);
  EXPECT_EQ(status, 0) << printed << "\n--- the exposition:\n" << text;
  EXPECT_EQ(printed, "") << text;
}

}  // namespace
}  // namespace panelbass::api

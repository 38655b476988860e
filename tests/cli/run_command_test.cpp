// `panelbass run`: a chain file on the virtual backend for a set time or until SIGINT, and the metrics
// it prints on exit.

#include <gtest/gtest.h>

#include <cstdlib>
#include <regex>

#include "api/model_store.h"
#include "models/io/json_file.h"
#include "models/linear/linear_model.h"
#include "tests/support/cli_runner.h"
#include "tests/support/controllers.h"

namespace panelbass {
namespace {

using namespace testing_support;

// The feedforward controller of the test chain: u − 0.2·u(k−1), a gain of 0.8 at DC and at most 1.2.
json gain_model() { return fir_gain_controller(-0.2); }

class CliRun : public CliTest {
 protected:
  // A chain with a band-pass and gain_model() as its feedforward (inline).
  fs::path chain() const {
    json j = json::parse(R"({"format":"panelbass.chain/1","fs":3000,"block":64,
        "band_pass":{"low_hz":20,"high_hz":1200,"order":2}})");
    j["feedforward"] = {{"model", gain_model()}};
    models::write_json_file(dir_ / "chain.json", j);
    return dir_ / "chain.json";
  }
};

void expect_healthy_metrics(const json& metrics) {
  EXPECT_GT(metrics["blocks"].get<long>(), 0) << metrics;
  EXPECT_EQ(metrics["samples"].get<long>(), 64 * metrics["blocks"].get<long>()) << metrics;
  EXPECT_EQ(metrics["faults"], 0) << metrics;
  EXPECT_EQ(metrics["in_fault"], false) << metrics;
  EXPECT_EQ(metrics["last_fault"], "none") << metrics;
  for (const char* key : {"xruns", "mean_block_ns", "p99_block_ns", "max_block_ns", "load"}) {
    EXPECT_TRUE(metrics[key].is_number()) << key << ": " << metrics;
  }
  // Model ids as the API writes them ("m" + 12 hex digits): the feedforward's is the id the store gives it.
  EXPECT_EQ(metrics["active_ids"]["feedforward"], api::model_store_id(gain_model())) << metrics;
  EXPECT_TRUE(std::regex_match(metrics["active_ids"]["band_pass"].get<std::string>(), std::regex("m[0-9a-f]{12}")))
      << metrics;
  EXPECT_TRUE(metrics["active_ids"]["feedback"].is_null()) << metrics;
  // A gain of 0.8 on band-passed noise of peak 0.3 (the default program) stays within the limiter's knee.
  EXPECT_EQ(metrics["limited_samples"], 0) << metrics;
  EXPECT_EQ(metrics["over_range_samples"], 0) << metrics;
}

TEST_F(CliRun, TheVirtualBackendRunsForOneSecondWithoutAFault) {
  const json r = expect_result(run("run --chain " + quoted(chain()) + " --backend virtual --seconds 1"));
  EXPECT_EQ(r["backend"], "virtual");
  EXPECT_EQ(r["plant"], "panel-exciter");
  EXPECT_EQ(r["program"]["signal"], "noise");
  EXPECT_EQ(r["interrupted"], false);
  EXPECT_GE(r["seconds"].get<double>(), 1.0);
  expect_healthy_metrics(r["metrics"]);
}

TEST_F(CliRun, ASineProgramLoopsWithoutAClickAtAnExactFrequency) {
  const json r = expect_result(run("run --chain " + quoted(chain()) + " --signal sine:80 --amplitude 0.5 --seconds 0.5"));
  EXPECT_EQ(r["program"]["signal"], "sine");
  // 80 Hz at 3000 Hz: 75 samples hold exactly 2 periods.
  EXPECT_DOUBLE_EQ(r["program"]["frequency_hz"].get<double>(), 80.0);
  expect_healthy_metrics(r["metrics"]);
}

TEST_F(CliRun, SigintEndsTheRunAndTheMetricsArePrinted) {
  // Started in the background; interrupted once it says it runs (after its signal handlers are in place).
  const fs::path out = dir_ / "out.txt", err = dir_ / "err.txt";
  const std::string command = quoted(std::string(PANELBASS_BIN)) + " run --chain " + quoted(chain()) +
                              " --backend virtual </dev/null >" + quoted(out) + " 2>" + quoted(err) +
                              " & pid=$!; for i in $(seq 600); do grep -q 'Ctrl-C' " + quoted(err) +
                              " && break; sleep 0.1; done; sleep 0.3; kill -INT $pid; wait $pid";
  const int raw = std::system(command.c_str());
  ASSERT_TRUE(raw != -1 && WIFEXITED(raw)) << raw;
  EXPECT_EQ(WEXITSTATUS(raw), 0) << text_of(err);
  const json r = json::parse(text_of(out));
  EXPECT_EQ(r["interrupted"], true);
  expect_healthy_metrics(r["metrics"]);
}

TEST_F(CliRun, AnAlsaDeviceThatNeverOpensFailsNamingItAndItsError) {
  // The backend retries a lost device with back-off; a run during which it never opened is a failure.
  const RunResult r = run("run --chain " + quoted(chain()) + " --backend alsa --playback panelbass_no_such_pcm --seconds 0.5");
  // Progress lines came first (the run was under way); the error is the last line, and no result.
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(r.out, "");
  const std::string last = r.err.substr(r.err.rfind('\n', r.err.size() - 2) + 1);
  EXPECT_EQ(last.rfind("panelbass: error: --backend alsa: the devices never opened (playback \"panelbass_no_such_pcm\"", 0), 0u)
      << r.err;
  // A bad channel map is refused before anything opens.
  const RunResult map = run("run --chain " + quoted(chain()) + " --backend alsa --playback null --sensor-channel 1 --seconds 0.5");
  expect_failure(map);
  EXPECT_TRUE(contains(map.err, "sensor_channel is set but no capture device is named")) << map.err;
}

TEST_F(CliRun, BadInputFailsNamingWhatIsWrong) {
  const fs::path c = chain();
  const RunResult signal = run("run --chain " + quoted(c) + " --signal square --seconds 1");
  expect_failure(signal);
  EXPECT_TRUE(contains(signal.err, "--signal square")) << signal.err;
  const RunResult nyquist = run("run --chain " + quoted(c) + " --signal sine:2000 --seconds 1");
  expect_failure(nyquist);
  EXPECT_TRUE(contains(nyquist.err, "sine:2000")) << nyquist.err;
  const RunResult missing = run("run --chain " + quoted(dir_ / "none.json") + " --seconds 1");
  expect_failure(missing);
  EXPECT_TRUE(contains(missing.err, "none.json")) << missing.err;
  const RunResult program = run("run --chain " + quoted(c) + " --program " + quoted(dir_ / "absent.wav") + " --seconds 1");
  expect_failure(program);
  EXPECT_TRUE(contains(program.err, "absent.wav")) << program.err;
  expect_usage_error(run("run --chain " + quoted(c) + " --backend jack"));
}

}  // namespace
}  // namespace panelbass

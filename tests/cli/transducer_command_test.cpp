// `panelbass transducer --jack` as a user runs it: --help shows an example; against a JACK server with the dummy driver it runs the
// plant at the server's rate for the time asked and reports what it simulated; without --jack it is bad
// usage; with no server to connect to it fails naming that.
//
// Independent expectation: the dummy driver runs in real time, so a one-second run simulates about one
// second of frames at the server's rate (between a quarter and four times, the machine being shared).
#include <gtest/gtest.h>
#include <unistd.h>

#include <string>

#include "tests/support/cli_runner.h"
#include "tests/support/jack_server.h"

namespace panelbass {
namespace {

using namespace testing_support;

TEST_F(CliTest, TransducerRunsThePlantAsAJackClient) {
  const RunResult help = run("transducer --help");
  EXPECT_EQ(help.status, 0);
  EXPECT_TRUE(contains(help.out, "Example")) << help.out;
  expect_usage_error(run("transducer --plant linear --seconds 1"));
  if (skip_jack()) GTEST_SKIP() << "PANELBASS_SKIP_JACK=1";
  const RunResult none = run("transducer --jack --server panelbass-nobody-" + std::to_string(::getpid()) + " --seconds 1");
  expect_failure(none);
  EXPECT_TRUE(contains(none.err, "JACK")) << none.err;

  JackServer jack("panelbass-tr-" + std::to_string(::getpid()), 48000.0, 64);
  const std::string started = jack.start();
  ASSERT_EQ(started, "") << started;
  const nlohmann::json result = expect_result(run("transducer --jack --server " + jack.name() + " --plant linear --seconds 1"));
  EXPECT_EQ(result["rate"], 48000.0);
  EXPECT_EQ(result["plant"], "linear");
  EXPECT_GT(result["frames"].get<double>(), 12000.0);
  EXPECT_LT(result["frames"].get<double>(), 4.0 * 48000.0);
  EXPECT_EQ(result["peak_drive"], 0.0) << "nothing drives it";
}

}  // namespace
}  // namespace panelbass

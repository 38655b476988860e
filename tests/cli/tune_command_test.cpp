// `panelbass tune` as a user runs it: --help shows the sound card's example; through a sound card (the ALSA backend
// over ALSA's jack plugin, as measure's test runs it) the multisine is measured through the card — so a card whose
// capture has no coil current channel is named after that measurement (exit 1), the filter being fitted from the
// current — and a multisine above the card's safe level is bad usage naming --amplitude and the level.
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <string>

#include "tests/support/cli_runner.h"
#include "tests/support/jack_server.h"

namespace panelbass {
namespace {

using namespace testing_support;

TEST_F(CliTest, TuneHelpShowsTheSoundCardsExample) {
  const RunResult help = run("tune --help");
  EXPECT_EQ(help.status, 0);
  EXPECT_TRUE(contains(help.out, "Examples")) << help.out;
  EXPECT_TRUE(contains(help.out, "panelbass tune --backend alsa")) << help.out;
  EXPECT_TRUE(contains(help.out, "--safe-level")) << help.out;
}

TEST_F(CliTest, TuneWritesItsMeasurementWhichDesignMirrorReadsAgain) {
  const RunResult tuned = run("tune --plant panel-exciter --quiet-sensor --samples 3000 --probes 80 --levels 0.2"
                              " --no-refine --record " + quoted(dir_ / "tune.csv"));
  EXPECT_EQ(tuned.status, 0) << tuned.err;
  std::ifstream csv(dir_ / "tune.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header, "u,y,i");  // the multisine as sent, the sensor, the current (the virtual backend loops nothing back)
  std::size_t rows = 0;
  for (std::string line; std::getline(csv, line);) rows += !line.empty();
  EXPECT_EQ(rows, 3000u);
  const RunResult again = run("design mirror --data " + quoted(dir_ / "tune.csv") + " --fs 3000 --current-only --out " +
                              quoted(dir_ / "mirror.json"));
  EXPECT_EQ(again.status, 0) << again.err;
}

TEST_F(CliTest, TuneThroughACardMeasuresThereAndNamesAMissingCurrent) {
  if (skip_jack()) GTEST_SKIP() << "PANELBASS_SKIP_JACK=1";
  const std::string tag = "pbt" + std::to_string(::getpid());
  JackServer jack("panelbass-tune-" + std::to_string(::getpid()), kDeviceRate, kPeriod);
  const std::string started = jack.start_as_default();
  ASSERT_EQ(started, "") << started;
  std::ofstream((dir_ / "card.conf")) << loopback_config(tag);
  const std::string card = "tune --backend alsa --alsa-config " + quoted((dir_ / "card.conf")) +
                           " --playback pb_play --capture pb_capture --rate 48000 --period 64 --periods 8"
                           " --loopback-channel 1 --sensor-channel 1 --plant panel-exciter --safe-level 0.3"
                           " --samples 3000 --probes 80 --no-refine";
  // the use case's check on the card's safe level: before anything is played
  const RunResult loud = run(card + " --amplitude 0.4");
  expect_usage_error(loud);
  EXPECT_TRUE(contains(loud.err, "--amplitude")) << loud.err;
  EXPECT_TRUE(contains(loud.err, "safe level 0.3")) << loud.err;
  // the default amplitude (0.5) within the safe level: measured through the card, then the missing current named
  const RunResult no_current = run(card);
  expect_failure(no_current);
  EXPECT_TRUE(contains(no_current.err, "records no coil current")) << no_current.err;
}

}  // namespace
}  // namespace panelbass

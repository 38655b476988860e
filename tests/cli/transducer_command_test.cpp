// `panelbass transducer --jack` as a user runs it: --help shows an example; against a JACK server with the dummy driver it runs the
// plant at the server's rate for the time asked and reports what it simulated; without --jack it is bad
// usage; with no server to connect to it fails naming that.
//
// Independent expectation: the dummy driver runs in real time, so a one-second run simulates about one
// second of frames at the server's rate (between a quarter and four times, the machine being shared).
//
// The THD log (--thd-log): an 80 Hz sine played through the card path (the ALSA backend over ALSA's jack plugin,
// the chain at 3000 Hz behind the rate bridge) into the client gives log lines at that frequency whose THD of
// the noise-free acceleration is dsp::steady_thd's of the same plant simulated directly (models::simulate at
// 48 kHz, plant_at_rate, the sensor's noise off) on a sine of the drive's logged fundamental. Tolerance 0.1 %
// of the THD: what differs is only what the card path adds to the drive besides its fundamental — the rate
// bridge's images (−80 dB, at 3000·k ± 80 Hz, no harmonic of 80 Hz), float32 samples (−150 dB) and the band-
// pass's residue of the start — against a THD that moves 1.4 % per 1 % of drive amplitude here (6.7 % at 0.1,
// 26 % at 0.3; docs/engine.md), and the drive's fundamental is read to better than 1e-4.
#include <gtest/gtest.h>
#include <unistd.h>

#include <string>

#include <algorithm>
#include <fstream>
#include <iostream>

#include "dsp/excitation.h"
#include "dsp/harmonics.h"
#include "engine/chain_file.h"
#include "engine/jack_transducer.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
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

TEST_F(CliTest, TheThdLogReadsTheSineItIsDrivenWithAndThePlantsOwnDistortion) {
  if (skip_jack()) GTEST_SKIP() << "PANELBASS_SKIP_JACK=1";
  const std::string id = std::to_string(::getpid());
  JackServer jack("panelbass-thd-" + id, kDeviceRate, kPeriod);
  const std::string started = jack.start_as_default();
  ASSERT_EQ(started, "") << started;
  // The card path plays an 80 Hz sine at 0.3 to a port the transducer connects its drive from.
  engine::ChainConfig config;
  config.fs = 3000.0;
  const std::unique_ptr<engine::Chain> chain = engine::make_chain(config);
  engine::AlsaOptions card = jack_card("pcm.pb_play { type jack name \"thd" + id +
                                           "\" playback_ports { 0 \"system:playback_1\" } }\n",
                                       kDeviceRate, kPeriod, 8, 0.3, 80.0);
  card.capture_device.clear();
  card.playback_channels = 1;
  card.realtime_priority = 0;
  engine::AlsaBackend backend(*chain, card);
  backend.start();
  for (const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
       backend.status().periods < 100 && std::chrono::steady_clock::now() < until;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_GE(backend.status().periods, 100u) << backend.status().last_error.data() << "\njackd:\n" << jack.log();

  const RunResult r = run("transducer --jack --plant panel-exciter --name thd-tr --drive-from thd" + id +
                          ":out_000 --thd-log " + quoted(dir_ / "thd.jsonl") + " --thd-window 1 --seconds 4");
  backend.stop();
  const nlohmann::json result = expect_result(r);
  ASSERT_GE(result["thd_lines"].get<int>(), 2) << result.dump();
  EXPECT_EQ(result["thd_dropped_frames"], 0);
  std::ifstream in(dir_ / "thd.jsonl");
  std::vector<nlohmann::json> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(lines.size(), result["thd_lines"].get<std::size_t>());
  // The last window whose drive is the clean sine (an xrun on a loaded machine leaves a gap in one; it plays
  // through whole windows before that one, so the plant is in its steady state).
  const auto clean = std::find_if(lines.rbegin(), lines.rend() - 1, [](const nlohmann::json& l) {
    return l["drive_thd_pct"].is_number() && l["drive_thd_pct"].get<double>() < 0.01;
  });
  ASSERT_NE(clean, lines.rend() - 1) << "no window after the first with a clean drive";
  const nlohmann::json& last = *clean;
  EXPECT_EQ(last["window_frames"], 48000);
  EXPECT_EQ(last["frames"].get<std::uint64_t>() % 48000, 0u) << "windows follow each other from the first frame";
  EXPECT_NEAR(last["frequency_hz"].get<double>(), 80.0, 1e-3);
  const double drive = last["drive_fundamental"].get<double>();
  EXPECT_NEAR(drive, 0.3, 0.01) << "the chain without models passes 80 Hz near unity";

  // The same plant simulated directly at the card's rate on a sine of that amplitude, its last second read alike.
  const models::PlantConfig plant =
      models::without_sensor_noise(engine::plant_at_rate(models::plant_preset("panel-exciter"), kDeviceRate));
  const Eigen::VectorXd sine = dsp::sine(96000, kDeviceRate, 80.0, drive);
  const models::PlantRecord direct = models::simulate(plant, sine, 1);
  const std::optional<dsp::SteadyThd> expected = dsp::steady_thd(direct.y.tail(48000), kDeviceRate, 80.0);
  ASSERT_TRUE(expected);
  const double thd = last["thd_clean_pct"].get<double>();
  std::cout << "THD log at 80 Hz, drive " << drive << ": noise-free " << thd << " % (direct simulation "
            << expected->measured_thd_pct << " %), sensor " << last["thd_sensor_pct"] << " % (floor "
            << last["thd_sensor_floor_pct"] << " %)\n";
  EXPECT_NEAR(thd, expected->measured_thd_pct, 0.001 * expected->measured_thd_pct);
  EXPECT_NEAR(last["clean_fundamental"].get<double>(), expected->fundamental, 0.001 * expected->fundamental);
  // The sensor reads the same fundamental through its noise (the preset's, at 48 kHz: a few % of it per window).
  EXPECT_NEAR(last["sensor_fundamental"].get<double>(), expected->fundamental, 0.05 * expected->fundamental);
  EXPECT_GT(last["thd_sensor_floor_pct"].get<double>(), 0.0);
}

}  // namespace
}  // namespace panelbass

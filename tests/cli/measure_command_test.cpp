// `panelbass measure` as a user runs it: --help shows an example; on the virtual transducer the record it writes is
// the plant's response to its drive (models::simulate on the CSV's own drive column, independently) with the drive
// through the plant's converters alone as the loopback column; through a sound card (the ALSA backend over ALSA's
// jack plugin, the drive looped back on capture channel 1 of a JACK dummy server) the card measurement protocol
// finds the round trip on the loopback and removes it, so the recorded channel is the drive itself, through the rate
// bridge.
//
// Independent expectation for the card: what comes back on the loopback is the drive through the rate bridge's
// interpolator and decimator (48 kHz ↔ 3000 Hz; minimum-phase at the default quality, so not the drive's waveform
// sample for sample) delayed by the card's buffers; with the round trip removed it lines up with the drive: their
// cross-correlation, computed here, peaks at lag 0.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <string>

#include "dsp/data_file.h"
#include "models/plant/converter_loop.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
#include "tests/support/cli_runner.h"
#include "tests/support/jack_server.h"

namespace panelbass {
namespace {

using namespace testing_support;

TEST_F(CliTest, MeasureOnTheVirtualTransducerWritesThePlantsResponse) {
  const RunResult help = run("measure --help");
  EXPECT_EQ(help.status, 0);
  EXPECT_TRUE(contains(help.out, "Examples")) << help.out;
  const nlohmann::json result = expect_result(
      run("measure --backend virtual --plant panel-exciter --quiet-sensor --samples 3000 --validation-samples 1000 "
          "--amplitude 0.4 --seed 5 --out " + quoted((dir_ / "est.csv")) + " --val-out " + quoted((dir_ / "val.csv"))));
  const models::PlantConfig plant = models::without_sensor_noise(models::plant_preset("panel-exciter"));
  double drive_energy = 0.0;
  for (const char* part : {"est.csv", "val.csv"}) {
    const dsp::Record r = dsp::read_data_file(dir_ / part, {"u", "y", "i", "l"}, plant.fs);
    const Eigen::VectorXd& u = r.column("u");
    const models::PlantRecord expected = models::simulate(plant, u, 1);
    EXPECT_LE((r.column("y") - expected.y).cwiseAbs().maxCoeff(), 1e-12 * expected.y.cwiseAbs().maxCoeff()) << part;
    EXPECT_LE((r.column("i") - expected.i).cwiseAbs().maxCoeff(), 1e-12 * expected.i.cwiseAbs().maxCoeff()) << part;
    const Eigen::VectorXd alone = models::converters_alone(plant, u);
    EXPECT_LE((r.column("l") - alone).cwiseAbs().maxCoeff(), 1e-12 * alone.cwiseAbs().maxCoeff()) << part;
    EXPECT_LE(u.cwiseAbs().maxCoeff(), 0.4);
    drive_energy += u.squaredNorm();
  }
  EXPECT_NEAR(result.at("rms_drive").get<double>(), std::sqrt(drive_energy / 4000.0), 1e-12);
  EXPECT_EQ(result.at("samples"), 3000);
  EXPECT_EQ(result.at("validation_samples"), 1000);
  // A validation part with nowhere to go, or too short to validate: bad usage, named.
  const RunResult nowhere = run("measure --out " + quoted((dir_ / "a.csv")));
  expect_usage_error(nowhere);
  EXPECT_TRUE(contains(nowhere.err, "--val-out")) << nowhere.err;
  const RunResult short_part = run("measure --validation-samples 100 --out " + quoted((dir_ / "a.csv")) + " --val-out " +
                                   quoted((dir_ / "b.csv")));
  expect_usage_error(short_part);
  EXPECT_TRUE(contains(short_part.err, "--validation-samples: must be 0 (none) or at least 200, got 100")) << short_part.err;
}

TEST_F(CliTest, MeasureThroughACardRemovesTheRoundTripFoundOnTheLoopback) {
  if (skip_jack()) GTEST_SKIP() << "PANELBASS_SKIP_JACK=1";
  const std::string tag = "pbm" + std::to_string(::getpid());
  JackServer jack("panelbass-measure-" + std::to_string(::getpid()), kDeviceRate, kPeriod);
  const std::string started = jack.start_as_default();
  ASSERT_EQ(started, "") << started;
  std::ofstream((dir_ / "card.conf")) << loopback_config(tag);
  const nlohmann::json result = expect_result(
      run("measure --backend alsa --alsa-config " + quoted((dir_ / "card.conf")) +
          " --playback pb_play --capture pb_capture --rate 48000 --period 64 --periods 8 --loopback-channel 1"
          " --sensor-channel 1 --plant panel-exciter --safe-level 0.5 --signal multisine --samples 3000"
          " --validation-samples 0 --amplitude 0.3 --seed 2 --out " + quoted((dir_ / "card.csv"))));
  ASSERT_EQ(result.at("card").size(), 1u) << result.dump();
  const nlohmann::json& card = result.at("card").at(0);
  EXPECT_EQ(card.at("calibrated_on"), "loopback");
  EXPECT_GE(card.at("attempts").get<int>(), 1);
  EXPECT_GT(card.at("round_trip_samples").get<int>(), 0) << "a card's buffers delay what comes back";
  const dsp::Record r = dsp::read_data_file((dir_ / "card.csv"), {"u", "y", "l"}, 3000.0);
  // The sensor channel is the loopback here: both are the drive as it came back, aligned to it.
  EXPECT_EQ(r.column("y"), r.column("l"));
  // The round trip is removed: what came back is aligned to the drive, its cross-correlation with the drive
  // largest at lag 0 among ±60 samples (the round trip itself is 37 at these settings, so a record left unaligned
  // would peak there).
  const Eigen::VectorXd& u = r.column("u");
  const Eigen::VectorXd& back = r.column("l");
  const Eigen::Index n = u.size(), margin = 60;
  Eigen::Index best_lag = -margin - 1;
  double best = -1.0;
  for (Eigen::Index lag = -margin; lag <= margin; ++lag) {
    const double c = u.segment(margin, n - 2 * margin).dot(back.segment(margin + lag, n - 2 * margin));
    if (c > best) {
      best = c;
      best_lag = lag;
    }
  }
  EXPECT_EQ(best_lag, 0);
}

}  // namespace
}  // namespace panelbass

// The service on a sound card with no sound card: a JACK server with the dummy driver, the virtual
// transducer as a JACK client (engine/jack_transducer.h, as `panelbass transducer --jack` runs it) and
// `serve --backend alsa` on two ALSA PCMs of type "jack": the playback's drive goes to the transducer's
// drive input; the capture hears the transducer's sensor (channel 0), the drive looped back (channel 1,
// which calibrates the round trip) and the coil current (channel 2).
//
// Independent expectations: the excite job's record, the card's round trip removed, lines up with the
// same plant simulated directly at 3000 Hz on the same drive (models::simulate, no card) within one sample
// — that simulation carries the plant's known converter delay; the linear model identified over HTTP from
// that record (and the model of the process alone, the card's converters removed through the loopback) has a
// validation J within 20 % of the same identification on the virtual backend, at the preset's sensor noise; the card
// reports no xrun, and its loopback is explained by the drive sample by sample (no slip: engine::check_loop);
// the drive stays within the safe level; the program plays again afterwards. A control excitation plays an LQ
// feedforward's drive through the card. Then the web's Tune runs as one tune job, short: measured through the
// card (the drive as sent and its loopback, the coil current from its channel), the mirror filter fitted from the
// current from whichever drive its model follows better (its free-run current J_val under 1 %), verified at equal output level through the card and kept — activated
// in the feedforward slot — because it cuts the THD; the same tune on the virtual backend keeps its filter too.
//
// A machine without jackd FAILS this test with a message saying what to install; only
// PANELBASS_SKIP_JACK=1 skips it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <thread>

#include "engine/jack_transducer.h"
#include "engine/measurement.h"
#include "models/io/json_fields.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"
#include "tests/api/server_fixture.h"
#include "tests/support/jack_server.h"

namespace panelbass::api {
namespace {

using namespace std::chrono_literals;
using api_testing::Reply;

using testing_support::kDeviceRate;
using testing_support::kPeriod;

// The ALSA configuration: the playback's channel 0 drives the transducer, the capture hears its sensor, the
// drive itself and its current.
std::string card_config(const std::string& tag, const std::string& transducer) {
  return "pcm.pb_play {\n"
         "  type jack\n"
         "  name \"" + tag + "p\"\n"
         "  playback_ports { 0 \"" + transducer + ":drive\" 1 \"system:playback_1\" }\n"
         "}\n"
         "pcm.pb_capture {\n"
         "  type jack\n"
         "  name \"" + tag + "c\"\n"
         "  capture_ports { 0 \"" + transducer + ":sensor\" 1 \"" + tag + "p:out_000\" 2 \"" + transducer + ":current\" }\n"
         "}\n";
}

Eigen::VectorXd column_of(const nlohmann::json& record, const char* name) {
  const std::vector<double> v = record.at(name).get<std::vector<double>>();
  return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

// The lag in [−max_lag, max_lag] at which y best matches x (x(k) against y(k + lag)), refined by a
// parabola through the peak and its neighbours.
double best_lag(const Eigen::VectorXd& x, const Eigen::VectorXd& y, int max_lag) {
  const auto c = [&](int lag) {
    double s = 0.0;
    for (Eigen::Index k = max_lag; k + max_lag < x.size(); ++k) s += x[k] * y[k + lag];
    return s;
  };
  int best = -max_lag;
  for (int lag = -max_lag; lag <= max_lag; ++lag) {
    if (c(lag) > c(best)) best = lag;
  }
  if (best == -max_lag || best == max_lag) return best;
  const double a = c(best - 1), b = c(best), d = c(best + 1), curvature = a - 2.0 * b + d;
  return curvature < 0.0 ? best + 0.5 * (a - d) / curvature : best;
}

class CardPipelineTest : public api_testing::ServerTest {
 protected:
  // Submits a job of `kind` with `params`, waits for it and expects it to succeed; returns its record.
  nlohmann::json run_job(const std::string& kind, const nlohmann::json& params) {
    const Reply submitted = post("/api/jobs", nlohmann::json{{"kind", kind}, {"params", params}});
    EXPECT_EQ(submitted.status, 202) << kind << ": " << submitted.text;
    const nlohmann::json job = wait_job(submitted.body.value("id", ""), 120s);
    EXPECT_EQ(job["state"], "succeeded") << kind << ": " << job.dump().substr(0, 2000);
    if (job["state"] != "succeeded") throw std::runtime_error(kind + " did not succeed");
    return job;
  }
};

TEST_F(CardPipelineTest, MeasuresIdentifiesAndTunesThroughTheCardAsOnTheVirtualBackend) {
  if (testing_support::skip_jack()) GTEST_SKIP() << "PANELBASS_SKIP_JACK=1";
  const std::string tag = "pbc" + std::to_string(::getpid());
  testing_support::JackServer jack("panelbass-card-" + std::to_string(::getpid()), kDeviceRate, kPeriod);
  const std::string started = jack.start_as_default();
  ASSERT_EQ(started, "") << started;

  // The preset as it is, its sensor noise included: verify reads each THD with the noise it stands on, plays
  // longer where that noise moves it, and says when a THD is at the floor.
  const models::PlantConfig plant = models::plant_preset("panel-exciter");
  engine::JackTransducerOptions t;
  t.plant = plant;
  t.client_name = tag + "t";
  t.noise_seed = 5;
  engine::JackTransducer transducer(t);
  ASSERT_EQ(transducer.rate(), kDeviceRate);

  ServerOptions o = options(dir_ / "store");
  o.engine.program.clear();
  // Slack for a shared machine (as the ALSA tests have): 16 periods (21 ms), SCHED_FIFO where granted, and a
  // device that may stall for 3 s before it counts as lost.
  engine::AlsaOptions card = testing_support::jack_card(card_config(tag, transducer.name()), kDeviceRate, kPeriod, 16, 0.2);
  card.device_timeout = 3000ms;
  card.capture_channels = 3;
  card.sensor_channel = 0;
  card.loopback_channel = 1;
  card.current_channel = 2;
  o.engine.alsa = card;
  o.engine.safe_level = 0.8;
  start(o);
  const nlohmann::json streaming = wait_status([](const nlohmann::json& s) {
    return s.is_object() && s["engine"]["device"]["state"] == "running" && s["metrics"]["blocks"].get<int>() > 100;
  });
  ASSERT_EQ(streaming["engine"]["device"]["state"], "running") << streaming.dump() << "\njackd:\n" << jack.log();

  // Beyond the safe level: refused at submission, naming it.
  const Reply loud = post("/api/jobs", std::string(R"({"kind":"excite","params":{"amplitude":0.9}})"));
  EXPECT_EQ(loud.status, 400) << loud.text;
  EXPECT_NE(loud.text.find("safe level"), std::string::npos) << loud.text;

  const auto began = std::chrono::steady_clock::now();
  const nlohmann::json excite_params = {{"signal", "noise"}, {"samples", 6000}, {"validation_samples", 3000},
                                        {"amplitude", 0.4}, {"seed", 1}};
  const std::string excite_id = run_job("excite", excite_params)["id"];
  const nlohmann::json excite = get("/api/jobs/" + excite_id).body;
  const nlohmann::json& result = excite["result"];
  ASSERT_TRUE(result.contains("card")) << "no calibration report";
  const nlohmann::json report = result["card"][0];
  EXPECT_EQ(report["calibrated_on"], "loopback");
  EXPECT_GT(report["peak_correlation"].get<double>(), 0.5) << report.dump();  // the bridge passes 0..1200 Hz of 0..1500
  EXPECT_LE(report["loop_residual"].get<double>(), engine::kLoopTolerance) << report.dump();

  // Aligned: the record against the plant simulated at 3000 Hz on the same drive (noise off).
  models::PlantConfig quiet = plant;
  quiet.sensor.noise_rms_V = 0.0;
  // The record is kept once in the record store: its estimation part is the first 6000 samples there.
  ASSERT_TRUE(result["record_id"].is_string()) << result.dump().substr(0, 300);
  const nlohmann::json kept = get("/api/records/" + result["record_id"].get<std::string>()).body["data"];
  const Eigen::VectorXd u = column_of(kept, "u").head(6000), y = column_of(kept, "y").head(6000);
  const Eigen::VectorXd y_direct = models::simulate(quiet, u, 1).y;
  const double lag = best_lag(y_direct, y, 8);
  const nlohmann::json first_status = get("/api/status").body;
  std::printf("[ card ] round trip %d samples at 3000 Hz (%.3f ms, correlation %.4f, loopback residual %.2e, %d "
              "attempt(s)); the record against the plant simulated directly: %.3f samples off; current captured: %s\n",
              report["round_trip_samples"].get<int>(), report["round_trip_ms"].get<double>(),
              report["peak_correlation"].get<double>(), report["loop_residual"].get<double>(),
              report["attempts"].get<int>(), lag, kept.contains("i") ? "yes" : "no");
  EXPECT_LE(std::abs(lag), 1.0) << "the record is not aligned with the plant's own delay";
  for (const nlohmann::json& part : result["card"]) {
    std::printf("[ card ] part: round trip %d, loopback residual %.2e, %d attempt(s)\n", part["round_trip_samples"].get<int>(),
                part["loop_residual"].get<double>(), part["attempts"].get<int>());
  }
  EXPECT_TRUE(kept.contains("i"));
  EXPECT_EQ(result["record_columns"], nlohmann::json({"u", "y", "i", "l"}));
  EXPECT_LE(u.cwiseAbs().maxCoeff(), 0.4);

  // Identification over HTTP through the card: the plain model, and the process alone from the loopback channel.
  const nlohmann::json identify = {{"record", excite_id}, {"method", "oe"}, {"order", 8}};
  const nlohmann::json card_job = run_job("identify-linear", identify);
  const double j_card = card_job["result"]["j_val_pct"].get<double>();
  nlohmann::json alone_params = identify;
  alone_params["process"] = "alone";
  const nlohmann::json alone_job = run_job("identify-linear", alone_params);
  const nlohmann::json alone_model = get("/api/models/" + alone_job["result"]["model_id"].get<std::string>()).body;
  EXPECT_EQ(alone_model["model"]["meta"]["process"].get<std::string>().rfind("alone", 0), 0u);
  // A control excitation plays the LQ feedforward's drive through the card.
  const std::string lq_id =
      run_job("design-lq", {{"plant_model", card_job["result"]["model_id"]}, {"max_input", 0.3}})["result"]["model_id"];
  run_job("excite", {{"signal", "control"}, {"feedforward_model", lq_id}, {"samples", 1500}, {"validation_samples", 1000}, {"seed", 2}});
  const double identified_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();

  // The web's Tune: one tune job, short (a 4 s multisine, two probes at one level) — measured through the card
  // (the drive and its loopback, the current channel), the mirror filter fitted from the current alone, verified
  // at equal output level through the card, and activated because it cuts.
  const nlohmann::json tune_params = {{"samples", 12000}, {"frequencies", {80, 160}}, {"levels", {0.2}}};
  const auto tune_began = std::chrono::steady_clock::now();
  const nlohmann::json card_tune = run_job("tune", tune_params);
  const double tune_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - tune_began).count();
  const nlohmann::json& tuned = card_tune["result"];
  EXPECT_EQ(tuned["backend"], "alsa");
  // the card loops the drive back: the fit tried both drives and kept the one its model follows better
  EXPECT_EQ(tuned["steps"][0]["summary"].value("loopback", false), true) << tuned["steps"][0].dump();
  const nlohmann::json& by_drive = tuned["summary"]["current_j_val_pct_by_drive"];
  ASSERT_TRUE(by_drive.contains("as sent") && by_drive.contains("loopback")) << by_drive.dump();
  EXPECT_EQ(tuned["summary"]["current_j_val_pct"],
            by_drive[by_drive["loopback"].get<double>() < by_drive["as sent"].get<double>() ? "loopback" : "as sent"]);
  EXPECT_LT(tuned["summary"]["current_j_val_pct"].get<double>(), 1.0) << tuned["summary"].dump().substr(0, 1500);
  ASSERT_TRUE(tuned["keep"].get<bool>()) << tuned["decision"] << "\n" << tuned["verify"].dump();
  EXPECT_EQ(card_tune["activated"]["slot"], "feedforward");
  EXPECT_EQ(get("/api/status").body["active_models"]["feedforward"], tuned["model_id"]);

  const nlohmann::json status = get("/api/status").body;
  EXPECT_EQ(status["engine"]["device"]["xruns"], 0) << status.dump();
  EXPECT_EQ(status["metrics"]["xruns"], 0) << status.dump();
  EXPECT_GT(status["metrics"]["blocks"].get<std::uint64_t>(), first_status["metrics"]["blocks"].get<std::uint64_t>())
      << "the program plays again";
  // The safe level: the drive's samples stay within it; the bridge's band-limited interpolation to 48 kHz may
  // peak a few percent beyond them between samples (0.821 seen with 8 s plays).
  EXPECT_LE(transducer.peak_drive(), 0.8 * 1.04);
  server_->stop();
  server_.reset();
  jack.stop();

  // The same identification and the same controllers on the virtual backend.
  ServerOptions on_virtual = options(dir_ / "virtual-store");
  on_virtual.engine.plant = plant;
  start(on_virtual);
  const nlohmann::json virtual_job = run_job("identify-linear", {{"excite", excite_params}, {"method", "oe"}, {"order", 8}});
  const double j_virtual = virtual_job["result"]["j_val_pct"].get<double>();
  // The tune on the virtual backend: kept too, its fit as good.
  const nlohmann::json virtual_tune = run_job("tune", tune_params);
  EXPECT_TRUE(virtual_tune["result"]["keep"].get<bool>()) << virtual_tune["result"]["decision"];
  const auto cut_text = [](const nlohmann::json& tune) {
    std::string text;
    for (const nlohmann::json& p : tune["result"]["verify"]["points"]) {
      char one[160];
      const nlohmann::json& cut = p["thd_cut_db"].is_number() ? p["thd_cut_db"] : p["thd_cut_at_least_db"];
      std::snprintf(one, sizeof one, "%s%g Hz %s%s dB", text.empty() ? "" : ", ", p["frequency_hz"].get<double>(),
                    p["thd_cut_db"].is_number() ? "" : ">= ", cut.is_number() ? std::to_string(cut.get<double>()).substr(0, 5).c_str() : "?");
      text += one;
    }
    return text;
  };
  std::printf("[ card ] tune through the card (%.1f s): current J_val %.4f %%, %s; %s\n", tune_s,
              tuned["summary"]["current_j_val_pct"].get<double>(), cut_text(card_tune).c_str(), tuned["decision"].get<std::string>().c_str());
  std::printf("[ card ] tune on the virtual backend: current J_val %.4f %%, %s\n",
              virtual_tune["result"]["summary"]["current_j_val_pct"].get<double>(), cut_text(virtual_tune).c_str());
  const nlohmann::json& card_fit = card_job["result"]["summary"];
  std::printf("[ card ] linear OE(8) J_val %.3f %% through the card (delay %d: %s; process alone %.3f %%), %.3f %% on the "
              "virtual backend; identification and the control excitation on the card path %.1f s\n",
              j_card, card_fit["delay"].get<int>(), card_fit["nk_source"].get<std::string>().c_str(),
              alone_job["result"]["j_val_pct"].get<double>(), j_virtual, identified_s);
  // At the preset's noise the noise is most of J; the card's own converters (the rate bridge's filters) add a
  // little to the plain model's (measured 2.55 % against 2.37 %), and the process alone leaves them out,
  // identifying what the virtual backend's identification sees: the plant with its own converters.
  EXPECT_NEAR(alone_job["result"]["j_val_pct"].get<double>(), j_virtual, 0.2 * j_virtual);
  // In 3 runs of 13 the delay estimate (the impulse response's first significant tap) read lag 1 on the card's
  // record where it reads 2 on the virtual backend's, and OE(8) from nk = 1 stopped at J 5.8–6.0 %; identification
  // now fits an estimated delay one lag later too and keeps the lower J (models/linear/linear_identification.cpp).
  EXPECT_NEAR(j_card, j_virtual, 0.2 * j_virtual) << "the plain model through the card: " << card_fit.dump().substr(0, 1500);
}

}  // namespace
}  // namespace panelbass::api

// `panelbass render`: a WAV file through a chain file, checked against numbers computed here: the
// band-pass evaluated directly with dsp::SosFilter at the chain's rate, a sine's closed-form response
// after a round trip through 48 kHz, the plant simulated with models::simulate (bare and linearised),
// J_c recomputed from the written columns, and the bare THD against `panelbass harmonics`.

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>

#include "dsp/butterworth.h"
#include "dsp/excitation.h"
#include "dsp/wav_file.h"
#include "models/io/json_file.h"
#include "models/control/lq_feedforward.h"
#include "models/plant/plant_presets.h"
#include "models/linear/linear_model.h"
#include "models/linear/state_space.h"
#include "models/linear/transfer_function.h"
#include "models/plant/virtual_transducer.h"
#include "tests/support/cli_runner.h"
#include "tests/support/controllers.h"

namespace panelbass {
namespace {

using namespace testing_support;

class CliRender : public CliTest {
 protected:
  // A band-pass-only chain file (20–1200 Hz, order 2, at 3000 Hz).
  fs::path band_pass_chain() const {
    return file("chain.json", R"({"format":"panelbass.chain/1","fs":3000,"block":64,
        "band_pass":{"low_hz":20,"high_hz":1200,"order":2}})");
  }

  // A one-column float WAV named `name` with column "program".
  fs::path wav(const std::string& name, const Eigen::VectorXd& x, double fs) const {
    dsp::Record r;
    r.fs = fs;
    r.add("program", x);
    dsp::write_wav(dir_ / name, r, dsp::WavFormat::float32);
    return dir_ / name;
  }
};

// Uniform noise in ±amplitude (dsp::uniform_noise).
Eigen::VectorXd noise(std::size_t n, double amplitude, std::uint64_t seed) { return dsp::uniform_noise(n, amplitude, seed); }

TEST_F(CliRender, ABandPassChainEqualsTheFilterEvaluatedDirectly) {
  const fs::path in = wav("in.wav", noise(6000, 0.5, 3), 3000.0);
  const fs::path out = dir_ / "out.wav";
  const json r = expect_result(
      run("render --chain " + quoted(band_pass_chain()) + " --in " + quoted(in) + " --out " + quoted(out)));
  EXPECT_EQ(r["resampled"], false);
  EXPECT_EQ(r["samples_chain"], 6000);
  EXPECT_EQ(r["faults"], 0);
  EXPECT_EQ(r["columns"], json::array({"drive"}));
  EXPECT_FALSE(r.contains("j_c_pct"));

  // The program as the command read it (float32), filtered here.
  const Eigen::VectorXd program = dsp::read_wav(in, {"program"}).columns.front();
  const Eigen::VectorXd expected = dsp::SosFilter(dsp::butterworth_bandpass(2, 20.0, 1200.0, 3000.0)).process(program);
  const dsp::Record written = dsp::read_wav(out, {"drive"});
  EXPECT_EQ(written.fs, 3000.0);
  ASSERT_EQ(written.samples(), 6000u);
  EXPECT_LE((written.columns.front() - expected).cwiseAbs().maxCoeff(), 1e-6);
}

TEST_F(CliRender, A48kHzFileIsRenderedAtTheChainsRateAndComesBackAt48kHz) {
  // 2 s of a 100 Hz sine at 48 kHz: after the band-pass, |H(100)|·0.5·sin(2π·100·t + arg H(100)).
  const double f = 100.0;
  const fs::path in = wav("in48k.wav", dsp::sine(96000, 48000.0, f, 0.5), 48000.0);
  const fs::path out = dir_ / "out48k.wav";
  const json r = expect_result(
      run("render --chain " + quoted(band_pass_chain()) + " --in " + quoted(in) + " --out " + quoted(out) + " --channel program"));
  EXPECT_EQ(r["resampled"], true);
  EXPECT_EQ(r["fs_in"], 48000.0);
  EXPECT_EQ(r["fs_chain"], 3000.0);
  EXPECT_EQ(r["samples_chain"], 6000);

  const dsp::Record written = dsp::read_wav(out, {"drive"});
  EXPECT_EQ(written.fs, 48000.0);
  ASSERT_EQ(written.samples(), 96000u);
  const std::complex<double> h = dsp::SosFilter(dsp::butterworth_bandpass(2, 20.0, 1200.0, 3000.0)).response(f, 3000.0);
  double worst = 0.0;
  // From 0.5 s (the band-pass has settled) to 0.1 s before the end (the resampler's edge).
  for (Eigen::Index k = 24000; k < 96000 - 4800; ++k) {
    const double t = static_cast<double>(k) / 48000.0;
    const double expected = 0.5 * std::abs(h) * std::sin(2.0 * std::numbers::pi * f * t + std::arg(h));
    worst = std::max(worst, std::abs(written.columns.front()[k] - expected));
  }
  EXPECT_LE(worst, 1e-4);
}

TEST_F(CliRender, WithAPlantItWritesBothTransducerOutputsAndTheirThdAndJc) {
  const Eigen::VectorXd sine = dsp::sine(9000, 3000.0, 80.0, 0.5);
  const fs::path in = wav("sine.wav", sine, 3000.0);
  const fs::path out = dir_ / "plant.wav";
  const json r = expect_result(run("render --chain " + quoted(band_pass_chain()) + " --in " + quoted(in) + " --out " +
                                   quoted(out) + " --plant panel-exciter --seed 5"));
  EXPECT_EQ(r["columns"], json::array({"drive", "y", "y_bare", "y_desired"}));
  EXPECT_EQ(r["plant"], "panel-exciter");
  EXPECT_NEAR(r["sine"]["frequency_hz"].get<double>(), 80.0, 1e-6);

  const dsp::Record w = dsp::read_wav(out, {"drive", "y", "y_bare", "y_desired"});
  const Eigen::VectorXd program = dsp::read_wav(in, {"program"}).columns.front();
  const models::PlantConfig plant = models::plant_preset("panel-exciter");
  // The bare drive is the program itself, with the same sensor noise seed.
  const Eigen::VectorXd bare = models::simulate(plant, program, 5).y;
  EXPECT_LE((w.columns[2] - bare).cwiseAbs().maxCoeff(), 1e-6 * bare.cwiseAbs().maxCoeff());
  // The desired response: the band-passed program through the linearised, noise-free plant.
  models::PlantConfig linear = models::linearized(plant);
  linear.sensor.noise_rms_V = 0.0;
  const Eigen::VectorXd band = dsp::SosFilter(dsp::butterworth_bandpass(2, 20.0, 1200.0, 3000.0)).process(program);
  const Eigen::VectorXd desired = models::simulate(linear, band, 1).y;
  EXPECT_LE((w.columns[3] - desired).cwiseAbs().maxCoeff(), 1e-6 * desired.cwiseAbs().maxCoeff());
  // The chained transducer output is the plant driven by the chain's own drive.
  const Eigen::VectorXd chained = models::simulate(plant, w.columns[0], 5).y;
  EXPECT_LE((w.columns[1] - chained).cwiseAbs().maxCoeff(), 1e-4 * chained.cwiseAbs().maxCoeff());

  // [2C] recomputed from the columns as they are, J_c = Σ (y_desired − y)² / Σ y_desired² (the one J_c that
  // evaluate reports too: no offset is removed inside the figure).
  const auto j_c = [&](const Eigen::VectorXd& y) {
    return 100.0 * (w.columns[3] - y).squaredNorm() / w.columns[3].squaredNorm();
  };
  EXPECT_NEAR(r["j_c_pct"]["chained"].get<double>(), j_c(w.columns[1]), 1e-3 * j_c(w.columns[1]));
  EXPECT_NEAR(r["j_c_pct"]["bare"].get<double>(), j_c(w.columns[2]), 1e-3 * j_c(w.columns[2]));

  // The bare THD is the plant's at 80 Hz, 0.5, as `panelbass harmonics` measures it by stepped sine.
  const json h = expect_result(run("harmonics --plant panel-exciter --noise --freqs 80 --amplitudes 0.5"));
  const double reference = h["plant_rows"][0]["thd_pct"];
  EXPECT_NEAR(r["sine"]["thd_pct"]["bare"].get<double>(), reference, 0.05 * reference);
  EXPECT_GT(r["sine"]["thd_pct"]["chained"].get<double>(), 0.0);

  // Noise is not a sine: no THD, but J_c all the same.
  const json n = expect_result(run("render --chain " + quoted(band_pass_chain()) + " --in " +
                                   quoted(wav("noise.wav", noise(3000, 0.5, 4), 3000.0)) + " --out " +
                                   quoted(dir_ / "n.wav") + " --plant linear"));
  EXPECT_TRUE(n["sine"].is_null());
  EXPECT_TRUE(n["j_c_pct"]["bare"].is_number());
}

TEST_F(CliRender, WithAnLqFeedforwardTheDesiredResponseIsItsControlledLinearModel) {
  // A resonant linear model (poles 0.9·e^{±j0.3}), its LQ feedforward designed here with the thesis's weights.
  models::LinearModel model;
  Eigen::VectorXcd poles(2);
  poles << std::polar(0.9, 0.3), std::polar(0.9, -0.3);
  model.tf.a = models::polynomial_from_roots(poles).tail(2);
  model.tf.b = Eigen::Vector2d(0.05, 0.03);
  model.tf.nk = 1;
  model.fs = 3000.0;
  const models::LqFeedforward ff = models::design_lq(model, {3.0, 20.0});
  models::write_json_file(dir_ / "lq.json", models::lq_feedforward_to_json(ff));
  const fs::path chain = file("lq-chain.json", R"({"format":"panelbass.chain/1","fs":3000,
      "band_pass":{"low_hz":20,"high_hz":1200},"feedforward":{"model":"lq.json"}})");
  const fs::path in = wav("in.wav", noise(3000, 0.2, 6), 3000.0);
  const json r = expect_result(run("render --chain " + quoted(chain) + " --in " + quoted(in) + " --out " +
                                   quoted(dir_ / "lq.wav") + " --plant linear"));
  EXPECT_TRUE(contains(r["desired_response"].get<std::string>(), "LQ feedforward")) << r;
  // [7B] y_lin of the band-passed program.
  const Eigen::VectorXd program = dsp::read_wav(in, {"program"}).columns.front();
  const Eigen::VectorXd band = dsp::SosFilter(dsp::butterworth_bandpass(2, 20.0, 1200.0, 3000.0)).process(program);
  const Eigen::VectorXd desired = models::simulate(ff.desired(), band);
  const Eigen::VectorXd written = dsp::read_wav(dir_ / "lq.wav", {"y_desired"}).columns.front();
  EXPECT_LE((written - desired).cwiseAbs().maxCoeff(), 1e-6 * desired.cwiseAbs().maxCoeff());
}

TEST_F(CliRender, AProgramPastTheChainsSafeAmplitudeIsReportedAndOneBelowIsNot) {
  // A feedforward u + 2·u(k−1) (about 3 at 100 Hz) behind the band-pass.
  models::write_json_file(dir_ / "gain.json", testing_support::fir_gain_controller(2.0));
  const fs::path chain = file("gain-chain.json", R"({"format":"panelbass.chain/1","fs":3000,
      "band_pass":{"low_hz":20,"high_hz":1200},"feedforward":{"model":"gain.json"}})");
  const auto asked = [](const fs::path& in) {  // what the chain asks for, evaluated here
    const Eigen::VectorXd program = dsp::read_wav(in, {"program"}).columns.front();
    const Eigen::VectorXd band = dsp::SosFilter(dsp::butterworth_bandpass(2, 20.0, 1200.0, 3000.0)).process(program);
    Eigen::VectorXd out = band;
    for (Eigen::Index k = 1; k < band.size(); ++k) out(k) += 2.0 * band(k - 1);
    return out;
  };
  // 0.4 asks ≈ 1.2: past full scale.
  const fs::path loud = wav("loud.wav", dsp::sine(3000, 3000.0, 100.0, 0.4), 3000.0);
  const RunResult over = run("render --chain " + quoted(chain) + " --in " + quoted(loud) + " --out " + quoted(dir_ / "l.wav"));
  const json r = expect_result(over);
  const Eigen::VectorXd a = asked(loud);
  const auto over_range = static_cast<std::uint64_t>((a.array().abs() >= 1.0).count());
  ASSERT_GT(over_range, 100u);
  EXPECT_EQ(r["drive_demand"]["needs_more_drive"], true) << r;
  EXPECT_EQ(r["drive_demand"]["over_range_samples"].get<std::uint64_t>(), over_range);
  EXPECT_NEAR(r["drive_demand"]["peak_demand"].get<double>(), a.cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LE(r["drive_peak"].get<double>(), 1.0);
  EXPECT_TRUE(contains(over.err, "needs more drive")) << over.err;
  // 0.25 asks ≈ 0.75: inside the limiter's knee.
  const fs::path quiet = wav("quiet.wav", dsp::sine(3000, 3000.0, 100.0, 0.25), 3000.0);
  const RunResult under = run("render --chain " + quoted(chain) + " --in " + quoted(quiet) + " --out " + quoted(dir_ / "q.wav"));
  const json q = expect_result(under);
  EXPECT_EQ(q["drive_demand"]["needs_more_drive"], false) << q;
  EXPECT_EQ(q["drive_demand"]["over_range_samples"], 0);
  // (the band-pass's start may overshoot the knee for a few samples: the limiter compresses them, below full scale)
  const Eigen::VectorXd b = asked(quiet);
  EXPECT_EQ(q["drive_demand"]["limited_samples"].get<std::uint64_t>(),
            static_cast<std::uint64_t>((b.array().abs() > 0.8).count()));
  EXPECT_NEAR(q["drive_demand"]["peak_demand"].get<double>(), b.cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT(b.cwiseAbs().maxCoeff(), 1.0);
  EXPECT_FALSE(contains(under.err, "needs more drive")) << under.err;
}

TEST_F(CliRender, BadInputFailsNamingWhatIsWrong) {
  const fs::path chain = band_pass_chain();
  const fs::path in = wav("in.wav", noise(1000, 0.5, 3), 3000.0);
  const fs::path out = dir_ / "out.wav";

  const RunResult missing = run("render --chain " + quoted(chain) + " --in " + quoted(dir_ / "absent.wav") + " --out " + quoted(out));
  expect_failure(missing);
  EXPECT_TRUE(contains(missing.err, "absent.wav")) << missing.err;

  const fs::path bad_chain = file("bad.json", R"({"format":"panelbass.chain/1","fs":3000,"band_pas":{}})");
  const RunResult key = run("render --chain " + quoted(bad_chain) + " --in " + quoted(in) + " --out " + quoted(out));
  expect_failure(key);
  EXPECT_TRUE(contains(key.err, "bad.json: chain.band_pas: unknown key")) << key.err;

  const RunResult channel = run("render --chain " + quoted(chain) + " --in " + quoted(in) + " --out " + quoted(out) + " --channel 3");
  expect_failure(channel);
  EXPECT_TRUE(contains(channel.err, "in.wav") && contains(channel.err, "3")) << channel.err;
  const RunResult named = run("render --chain " + quoted(chain) + " --in " + quoted(in) + " --out " + quoted(out) + " --channel nope");
  expect_failure(named);
  EXPECT_TRUE(contains(named.err, "nope")) << named.err;

  const RunResult missing_chain = run("render --chain " + quoted(dir_ / "none.json") + " --in " + quoted(in) + " --out " + quoted(out));
  expect_failure(missing_chain);
  EXPECT_TRUE(contains(missing_chain.err, "none.json")) << missing_chain.err;
  EXPECT_FALSE(fs::exists(out));

  expect_usage_error(run("render --chain " + quoted(chain) + " --in " + quoted(in)));
}

TEST_F(CliRender, HelpShowsAnExample) {
  const RunResult r = run("render --help");
  EXPECT_EQ(r.status, 0);
  EXPECT_TRUE(contains(r.out, "Example:")) << r.out;
}

}  // namespace
}  // namespace panelbass

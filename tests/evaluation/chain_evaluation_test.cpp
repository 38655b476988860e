// The Control issue's evaluation table, on the `linear` preset where the answers are known: a linear
// plant has no harmonics, an LQ feedforward designed on a model of it flattens its response, and the
// loop output then tracks the desired response to within the sensor noise.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "dsp/butterworth.h"
#include "dsp/random.h"
#include "evaluation/chain_evaluation.h"
#include "evaluation/distortion_attribution.h"
#include "models/linear/linear_identification.h"
#include "models/control/feedback_training.h"
#include "models/control/lq_feedforward.h"
#include "models/control/neural_feedback.h"
#include "models/plant/plant_presets.h"
#include "models/linear/state_space.h"
#include "models/plant/virtual_transducer.h"
#include "tests/engine/engine_test_models.h"

namespace panelbass::evaluation {
namespace {

using namespace engine;  // the chain under evaluation

// An OE model of the linear preset from 8000 samples of full-drive noise, and the LQ controller on it.
nlohmann::json lq_on_linear_plant(const models::PlantConfig& plant) {
  dsp::Rng rng(5);
  Eigen::VectorXd u(8000);
  for (Eigen::Index k = 0; k < u.size(); ++k) u[k] = rng.uniform(-1.0, 1.0);
  const Eigen::VectorXd y = models::simulate(plant, u, 6).y;
  models::LinearIdentificationSpec spec;
  spec.method = models::LinearMethod::oe;
  spec.order = 8;
  spec.fs = plant.fs;
  const models::LinearModel model = models::identify_linear(u, y, {}, {}, spec).model;
  return models::lq_feedforward_to_json(models::design_lq(model, {1e-5, 20.0}));
}

// A chain of the default band-pass and that LQ feedforward, at the plant's rate.
ChainConfig lq_chain(const models::PlantConfig& plant) {
  ChainConfig config;
  config.fs = plant.fs;
  config.feedforward = SlotConfig{};
  config.feedforward->model = lq_on_linear_plant(plant);
  return config;
}

// A small neural feedback controller with random weights (seed 7) on an example NARX plant model, as the
// chain's feedback stage.
void add_example_feedback(ChainConfig& config) {
  models::FeedbackStructure structure;
  structure.nu = 2;
  structure.nv = 1;
  structure.ny = 2;
  structure.hidden = {4};
  config.feedback = SlotConfig{};
  config.feedback->model = models::neural_feedback_to_json(testing::example_feedback(structure, 3, 7, 0.05));
}

TEST(ChainEvaluationTest, OnALinearPlantTheFeedforwardFlattensAndNothingDistorts) {
  const models::PlantConfig plant = models::plant_preset("linear");
  ChainConfig config = lq_chain(plant);
  EvaluationOptions o;
  o.noise_samples = 30000;
  const ChainEvaluation e = evaluate_chain(config, plant, o);
  ASSERT_EQ(e.rows.size(), 2u);
  const EvaluationRow& bare = e.rows[0];
  const EvaluationRow& ff = e.rows[1];
  EXPECT_EQ(bare.name, "plant");
  EXPECT_GT(bare.ripple_db, 20.0) << "the panel's resonance and roll-off";
  EXPECT_LT(ff.ripple_db, bare.ripple_db / 2.0);
  // Through the sensor, the tracking error is the sensor's noise and little else: the noise is independent
  // of the output, so its power adds to the transducer's own error.
  EXPECT_LT(ff.jc_pct, 0.5) << "the feedforward was designed on a model of this very plant";
  EXPECT_NEAR(ff.measured_jc_pct, ff.jc_pct + e.jc_noise_floor_pct, 0.1 * e.jc_noise_floor_pct);
  EXPECT_NEAR(bare.measured_jc_pct, bare.jc_pct + e.jc_noise_floor_pct, 0.1 * (bare.jc_pct + e.jc_noise_floor_pct));
  EXPECT_GT(bare.jc_pct, 2.0 * ff.jc_pct);
  EXPECT_GT(e.noise_amplitude, 0.0);
  EXPECT_LE(ff.max_drive, 1.0);
  EXPECT_EQ(ff.faults, 0u);
  // each probe's steady drive: the program sine itself for the plant alone, and through band-pass and
  // feedforward its amplitude times their gain at the probe (recomputed here from the controller file)
  const models::LqFeedforward lq = models::lq_feedforward_from_json(config.feedforward->model);
  const std::vector<dsp::Biquad> bp = dsp::butterworth_band(2, 20.0, 1200.0, plant.fs);
  for (std::size_t i = 0; i < o.probe_hz.size(); ++i) {
    const double f = o.probe_hz[i];
    EXPECT_NEAR(bare.probes[i].drive_peak, bare.probes[i].amplitude, 0.01 * bare.probes[i].amplitude) << f;
    const double gain = std::abs(dsp::SosFilter(bp).response(f, plant.fs) * models::response(lq.controller(), f, plant.fs));
    EXPECT_NEAR(ff.probes[i].drive_peak, ff.probes[i].amplitude * gain, 0.01 * ff.probes[i].amplitude * gain) << f;
  }
  for (const EvaluationRow& row : e.rows) {
    ASSERT_EQ(row.probes.size(), o.probe_hz.size());
    for (const ProbeResult& p : row.probes) {
      EXPECT_LT(p.thd_pct, 1.0) << row.name << " at " << p.frequency_hz << " Hz: a linear plant has no harmonics";
      EXPECT_TRUE(std::isnan(p.model_thd_pct)) << "no neural feedback stage, no design model";
      EXPECT_GT(p.amplitude, 0.0);
      EXPECT_LE(p.amplitude, 1.0);
    }
    EXPECT_EQ(row.rest_drive_peak, 0.0) << row.name << ": linear stages drive nothing without a program";
  }
}

// With a neural feedback stage, every probe also reports the THD its design's NARX plant model predicts:
// recomputed here from the controller file alone, with a plain sine of the probe's amplitude (no fade: the
// steady state is the same), through the band-pass and the feedforward as the row runs them, and for the
// full chain the closed loop of fig. 7.10 on the model.
TEST(ChainEvaluationTest, EachProbeReportsTheThdTheDesignsPlantModelPredicts) {
  const models::PlantConfig plant = models::plant_preset("linear");
  ChainConfig config = lq_chain(plant);
  add_example_feedback(config);
  EvaluationOptions o;
  o.noise_samples = 4096;
  o.probe_hz = {40.0, 160.0};
  o.probe_peak = 0.6;
  const ChainEvaluation e = evaluate_chain(config, plant, o);
  ASSERT_EQ(e.rows.size(), 3u);

  const models::LqFeedforward lq = models::lq_feedforward_from_json(config.feedforward->model);
  const std::vector<dsp::Biquad> bp = dsp::butterworth_band(2, 20.0, 1200.0, plant.fs);
  const models::NeuralFeedback design = models::neural_feedback_from_json(config.feedback->model);
  for (std::size_t r = 0; r < e.rows.size(); ++r) {
    for (const ProbeResult& p : e.rows[r].probes) {
      Eigen::VectorXd sine(9000);
      for (Eigen::Index k = 0; k < sine.size(); ++k) {
        sine[k] = p.amplitude * std::sin(2.0 * std::numbers::pi * p.frequency_hz * static_cast<double>(k) / plant.fs);
      }
      Eigen::VectorXd y;
      if (r == 0) {
        y = design.plant.simulate(sine);
      } else {
        const Eigen::VectorXd u = models::simulate(lq.controller(), dsp::SosFilter(bp).process(sine));
        y = r == 1 ? design.plant.simulate(u) : models::simulate_closed_loop(design, u).y;
      }
      const double expected = dsp::harmonic_levels(y.tail(3000), plant.fs, p.frequency_hz, o.harmonics).thd_percent();
      EXPECT_GT(expected, 0.01) << "the example NARX distorts";
      EXPECT_NEAR(p.model_thd_pct, expected, 0.01 * expected) << e.rows[r].name << " at " << p.frequency_hz << " Hz";
    }
  }
  // With no program, the feedback stage drives what its closed loop with the model settles on: N1's offset.
  const Eigen::VectorXd rest = models::simulate_closed_loop(design, Eigen::VectorXd::Zero(9000)).v;
  EXPECT_NEAR(e.rows[2].rest_drive_peak, rest.tail(3000).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_GT(e.rows[2].rest_drive_peak, 1e-4) << "the example controller has an offset";
  EXPECT_EQ(e.rows[1].rest_drive_peak, 0.0);
  // The feedback changes what the model predicts.
  EXPECT_GT(std::abs(e.rows[2].probes[0].model_thd_pct - e.rows[1].probes[0].model_thd_pct),
            0.01 * e.rows[1].probes[0].model_thd_pct);
}

// Which term makes which harmonic, checked by physics rather than against the code: the Coulomb friction
// Fc·tanh(v/v0) is odd in v, so alone it makes no even harmonics; the amplifier's clipping does nothing
// below its knee; and where the distortion is small the terms' harmonics are first-order perturbations that
// do not interact, so their powers add up to the whole plant's (within what coherent H3s of two terms can
// make: 15 %).
TEST(ChainEvaluationTest, AttributionTracesEachProbesDistortionToTheTermsThatMakeIt) {
  const models::PlantConfig plant = models::plant_preset("panel-exciter");
  ChainConfig config = lq_chain(models::plant_preset("linear"));
  add_example_feedback(config);  // a feedback stage, which the attribution leaves out
  EvaluationOptions o;
  o.noise_samples = 4096;
  o.probe_hz = {160.0, 320.0};
  o.probe_peak = 0.6;
  const ChainEvaluation whole = evaluate_chain(config, plant, o);
  std::vector<std::string> seen;
  const std::vector<TermDistortion> terms =
      attribute_distortion(config, plant, o, [&](std::size_t done, std::size_t total, const std::string& term) {
        EXPECT_EQ(done, seen.size());
        EXPECT_EQ(total, 5u);
        seen.push_back(term);
      });
  const std::vector<std::string> expected{"stiffness", "force_factor", "inductance", "friction", "clipping"};
  EXPECT_EQ(seen, expected);
  ASSERT_EQ(terms.size(), expected.size());
  std::vector<double> power_sum(o.probe_hz.size(), 0.0);
  for (std::size_t t = 0; t < terms.size(); ++t) {
    EXPECT_EQ(terms[t].term, expected[t]);
    ASSERT_EQ(terms[t].rows.size(), 2u) << "plant and band-pass + feedforward, no feedback";
    const EvaluationRow& row = terms[t].rows[1];
    EXPECT_EQ(row.name, whole.rows[1].name);
    for (std::size_t p = 0; p < o.probe_hz.size(); ++p) {
      EXPECT_EQ(row.probes[p].amplitude, whole.rows[1].probes[p].amplitude) << "the same program at every probe";
      power_sum[p] += row.probes[p].thd_pct * row.probes[p].thd_pct;
      if (terms[t].term == "friction") {
        EXPECT_LT(row.probes[p].h2_db, -120.0) << o.probe_hz[p] << " Hz: an odd force has no even harmonics";
        EXPECT_LT(row.probes[p].harmonics_db[2], -120.0) << o.probe_hz[p] << " Hz (H4)";
        EXPECT_GT(row.probes[p].h3_db, -60.0) << o.probe_hz[p] << " Hz: but a strong third";
      }
      if (terms[t].term == "clipping") {
        EXPECT_LT(row.probes[p].drive_peak, plant.nonlinear.clipping.level - plant.nonlinear.clipping.knee);
        EXPECT_LT(row.probes[p].thd_pct, 1e-6) << o.probe_hz[p] << " Hz: below the knee nothing clips";
      }
    }
  }
  for (std::size_t p = 0; p < o.probe_hz.size(); ++p) {
    const double all = whole.rows[1].probes[p].thd_pct;
    ASSERT_LT(all, 2.0) << o.probe_hz[p] << " Hz: the small-distortion regime this check needs";
    EXPECT_NEAR(power_sum[p] / (all * all), 1.0, 0.15) << o.probe_hz[p] << " Hz";
  }
}

TEST(ChainEvaluationTest, RefusesAChainWithoutAnLqFeedforward) {
  ChainConfig config;
  EXPECT_THROW(evaluate_chain(config, models::plant_preset("linear")), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::evaluation

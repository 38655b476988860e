// The chain file: parsing with every validation error naming its key path and file, the JSON round
// trip, the classification of each kind of change, chains built from a file checked against the stages
// evaluated directly in the test (dsp::SosFilter from dsp::butterworth_*, the LQ controller's state space by
// models::simulate, the neural feedback's closed loop by models::simulate_closed_loop), and a change applied
// while the virtual backend plays.
#include "engine/chain_file.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "dsp/butterworth.h"
#include "engine/offline_renderer.h"
#include "engine/virtual_backend.h"
#include "models/io/config_error.h"
#include "models/io/json_file.h"
#include "models/plant/plant_presets.h"
#include "tests/engine/engine_test_models.h"
#include "tests/support/expect_error.h"
#include "tests/support/scratch_directory.h"

namespace panelbass::engine {
namespace {

using nlohmann::json;
using testing::kFs;
using testing_support::one_line_error;

// The example of the chain file's documentation, its models in ff.json and fb.json.
json example_json() {
  return json::parse(R"({"format":"panelbass.chain/1","fs":3000,"block":64,
    "band_pass":{"low_hz":20,"high_hz":1200,"order":2,"bypass":false},
    "feedforward":{"model":"ff.json","bypass":false},
    "feedback":{"model":"fb.json","source":"model","bypass":false},
    "crossfade_ms":20,"history":512,"limiter":{"knee":0.8,"pinned_level":1.0,"max_pinned_ms":100}})");
}

// `x` through a cascade of `sections`, from rest.
Eigen::VectorXd filtered(const std::vector<dsp::Biquad>& sections, const Eigen::VectorXd& x) {
  return dsp::SosFilter(sections).process(x);
}

// Processes `program` through `chain` in blocks of its max_block.
Eigen::VectorXd run(Chain& chain, const Eigen::VectorXd& program) {
  return render(chain, program, {Samples{chain.options().spec.max_block}, {}, 1}).drive;
}

class ChainFile : public testing_support::ScratchDirectoryTest {
 protected:
  ChainFile() {
    models::write_json_file(dir_ / "ff.json", models::lq_feedforward_to_json(testing::example_lq()));
    models::write_json_file(dir_ / "fb.json", models::neural_feedback_to_json(testing::chain_feedback()));
  }

  // The chain file `json` written as chain.json and loaded.
  ChainConfig load(const json& j) {
    file("chain.json", j.dump());
    return load_chain_file(dir_ / "chain.json");
  }

  // The message of loading the chain file `json`: one line, starting with the file's path.
  std::string error_of(const json& j) {
    file("chain.json", j.dump());
    const std::string message = one_line_error<models::ConfigError>([&] { load_chain_file(dir_ / "chain.json"); });
    EXPECT_EQ(message.rfind((dir_ / "chain.json").string() + ": ", 0), 0u) << message;
    return message;
  }

  // Expects loading `json` to fail with a message containing every one of `parts`.
  void expect_error(const json& j, const std::vector<std::string>& parts) {
    const std::string message = error_of(j);
    for (const std::string& part : parts) EXPECT_NE(message.find(part), std::string::npos) << message << "\n  lacks: " << part;
  }
};

TEST_F(ChainFile, ReadsTheDocumentedExample) {
  const ChainConfig c = load(example_json());
  EXPECT_EQ(c.fs, 3000.0);
  EXPECT_EQ(c.block, 64);
  EXPECT_EQ(c.band_pass.design.low.value, 20.0);
  EXPECT_EQ(c.band_pass.design.high.value, 1200.0);
  EXPECT_EQ(c.band_pass.design.order, 2);
  EXPECT_FALSE(c.band_pass.bypass);
  ASSERT_TRUE(c.feedforward && c.feedback);
  EXPECT_EQ(c.feedforward->path, "ff.json");
  EXPECT_EQ(c.feedforward->model, models::read_json_file(dir_ / "ff.json"));
  EXPECT_EQ(c.feedback->model, models::read_json_file(dir_ / "fb.json"));
  EXPECT_EQ(c.feedback->source, FeedbackSource::model);
  EXPECT_EQ(c.crossfade_ms, 20.0);
  EXPECT_EQ(c.history, 512);
  EXPECT_EQ(c.limiter.knee, 0.8);
  EXPECT_EQ(c.limiter.pinned_level, 1.0);
  EXPECT_EQ(c.limiter.max_pinned_ms, 100.0);

  // Times become samples at fs: 20 ms and 100 ms at 3000 Hz.
  const ChainOptions o = chain_options(c);
  EXPECT_EQ(o.spec.fs, 3000.0);
  EXPECT_EQ(o.spec.max_block, 64);
  EXPECT_EQ(o.slots.crossfade.value, 60);
  EXPECT_EQ(o.slots.history.value, 512);
  EXPECT_EQ(o.limiter.max_pinned.value, 300);
}

TEST_F(ChainFile, FillsDefaultsAndTakesInlineModelsAndTheSensorSource) {
  const ChainConfig minimal = load({{"format", "panelbass.chain/1"}, {"fs", 3000}});
  EXPECT_EQ(minimal.block, 64);
  EXPECT_EQ(minimal.band_pass.design.low.value, 20.0);
  EXPECT_EQ(minimal.band_pass.design.high.value, 1200.0);
  EXPECT_FALSE(minimal.feedforward.has_value());
  EXPECT_FALSE(minimal.feedback.has_value());

  json j = example_json();
  j["feedforward"]["model"] = models::lq_feedforward_to_json(testing::example_lq(1e-2));
  j["feedback"]["source"] = "sensor";
  j["feedback"]["bypass"] = true;
  const ChainConfig c = load(j);
  EXPECT_EQ(c.feedforward->path, "");
  EXPECT_EQ(c.feedforward->model, models::lq_feedforward_to_json(testing::example_lq(1e-2)));
  EXPECT_EQ(c.feedback->source, FeedbackSource::sensor);
  EXPECT_TRUE(c.feedback->bypass);
}

TEST_F(ChainFile, RejectsUnknownKeysByName) {
  json j = example_json();
  j["blok"] = 64;
  expect_error(j, {"chain.blok: unknown key"});
  j = example_json();
  j["band_pass"]["bypas"] = true;
  expect_error(j, {"chain.band_pass.bypas: unknown key"});
  j = example_json();
  j["feedforward"]["source"] = "model";  // only the feedback stage has a source
  expect_error(j, {"chain.feedforward.source: unknown key"});
  j = example_json();
  j["limiter"]["ceiling"] = 1;
  expect_error(j, {"chain.limiter.ceiling: unknown key"});
}

TEST_F(ChainFile, RejectsWrongTypesByName) {
  const std::vector<std::pair<json::json_pointer, json>> cases = {
      {json::json_pointer("/fs"), "3000"},
      {json::json_pointer("/block"), 64.5},
      {json::json_pointer("/band_pass"), 20},
      {json::json_pointer("/band_pass/high_hz"), "1200"},
      {json::json_pointer("/band_pass/order"), 2.5},
      {json::json_pointer("/band_pass/bypass"), "no"},
      {json::json_pointer("/feedforward/model"), 3},
      {json::json_pointer("/feedback/source"), 1},
      {json::json_pointer("/crossfade_ms"), true},
      {json::json_pointer("/limiter/knee"), nullptr},
  };
  for (const auto& [pointer, value] : cases) {
    json j = example_json();
    j[pointer] = value;
    std::string key = pointer.to_string().substr(1);
    for (char& ch : key) ch = ch == '/' ? '.' : ch;
    expect_error(j, {"chain." + key + ": expected"});
  }
}

TEST_F(ChainFile, RejectsAMissingOrWrongFormatAndAMissingRate) {
  json j = example_json();
  j.erase("format");
  expect_error(j, {"chain.format: expected \"panelbass.chain/1\", got nothing"});
  j["format"] = "panelbass.chain/2";
  expect_error(j, {"chain.format: expected \"panelbass.chain/1\", got \"panelbass.chain/2\""});
  j = example_json();
  j.erase("fs");
  expect_error(j, {"chain.fs: missing"});
  j["fs"] = 0;
  expect_error(j, {"chain.fs: must be within"});
}

TEST_F(ChainFile, RejectsCornersOutsideZeroToHalfTheRate) {
  const auto band = [](json low, json high) {
    json j = example_json();
    j["band_pass"]["low_hz"] = low;
    j["band_pass"]["high_hz"] = high;
    return j;
  };
  expect_error(band(20, 1500), {"chain.band_pass.high_hz: must be within (0, fs/2 = 1500) Hz, got 1500"});
  expect_error(band(20, 0), {"chain.band_pass.high_hz: must be within (0, fs/2 = 1500) Hz, got 0"});
  expect_error(band(-1, 1200), {"chain.band_pass.low_hz: must be within [0, fs/2 = 1500) Hz", "got -1"});
  expect_error(band(1200, 1200), {"chain.band_pass.low_hz: must be below high_hz = 1200 Hz, got 1200"});
  json j = example_json();
  j["band_pass"]["order"] = 0;
  expect_error(j, {"chain.band_pass.order: must be within [1, 16], got 0"});
  // 0 Hz is the low-pass-only band of the thesis's "0–1200 Hz".
  EXPECT_EQ(load(band(0, 1200)).band_pass.design.low.value, 0.0);
}

TEST_F(ChainFile, RejectsOutOfRangeTimesAndLimiterSettings) {
  json j = example_json();
  j["crossfade_ms"] = -1;
  expect_error(j, {"chain.crossfade_ms: must be within [0, 10000], got -1"});
  j = example_json();
  j["history"] = -1;
  expect_error(j, {"chain.history: must be within [0, 1048576], got -1"});
  j = example_json();
  j["block"] = 0;
  expect_error(j, {"chain.block: must be within [1, 8192], got 0"});
  j = example_json();
  j["limiter"]["knee"] = 1.0;
  expect_error(j, {"chain.limiter.knee: must be within [0, 1), got 1"});
  j = example_json();
  j["limiter"]["pinned_level"] = 0;
  expect_error(j, {"chain.limiter.pinned_level: must be within (0, 1] (full scale), got 0"});
  j = example_json();
  j["limiter"]["pinned_level"] = 1e308;  // above full scale the limited drive never counts as pinned: no trip
  expect_error(j, {"chain.limiter.pinned_level: must be within (0, 1] (full scale), got 1e+308"});
  j = example_json();
  j["limiter"]["max_pinned_ms"] = -5;
  expect_error(j, {"chain.limiter.max_pinned_ms: must be within [0, 1000], got -5"});
  j = example_json();
  j["limiter"]["max_pinned_ms"] = 60000;  // a minute of full-scale drive before the safe bypass
  expect_error(j, {"chain.limiter.max_pinned_ms: must be within [0, 1000], got 60000"});
  j = example_json();
  j["feedback"]["source"] = "both";
  expect_error(j, {"chain.feedback.source: expected \"model\" or \"sensor\", got \"both\""});
}

TEST_F(ChainFile, RejectsModelsThatAreMissingInvalidUnrunnableOrAtAnotherRate) {
  json j = example_json();
  j["feedforward"]["model"] = "missing.json";
  expect_error(j, {"chain.feedforward.model: ", (dir_ / "missing.json").string()});
  j = example_json();
  j["feedforward"].erase("model");
  expect_error(j, {"chain.feedforward.model: missing"});

  json bad = models::lq_feedforward_to_json(testing::example_lq());
  bad["params"].erase("L");
  models::write_json_file(dir_ / "bad.json", bad);
  j = example_json();
  j["feedforward"]["model"] = "bad.json";
  expect_error(j, {"chain.feedforward.model (" + (dir_ / "bad.json").string() + "): ", "model.params.L"});

  // A plant model is no controller: the registry gives it no slot.
  models::write_json_file(dir_ / "lin.json", models::linear_model_to_json(testing::example_linear()));
  j = example_json();
  j["feedforward"]["model"] = "lin.json";
  expect_error(j, {"chain.feedforward.model (" + (dir_ / "lin.json").string() + "): ",
                   "a linear plant model (kind linear): the feedforward slot takes lq_feedforward or mirror_filter"});
  j = example_json();
  j["feedback"]["model"] = "ff.json";
  expect_error(j, {"chain.feedback.model (" + (dir_ / "ff.json").string() + "): ",
                   "an LQ feedforward controller (kind lq_feedforward): the feedback slot takes neural_feedback"});

  json fast = models::neural_feedback_to_json(testing::chain_feedback());
  fast["fs"] = 48000.0;
  if (fast["plant"].contains("fs")) fast["plant"]["fs"] = 48000.0;
  models::write_json_file(dir_ / "fast.json", fast);
  j = example_json();
  j["feedback"]["model"] = "fast.json";
  expect_error(j, {"chain.feedback.model (" + (dir_ / "fast.json").string() + "): ",
                   "the model runs at fs = 48000 Hz, the chain at chain.fs = 3000 Hz"});

  j = example_json();
  j["feedback"]["model"] = json{{"format", "panelbass.model/1"}, {"kind", "kalman"}, {"fs", 3000}};
  expect_error(j, {"chain.feedback.model: ", "kind \"kalman\""});
}

TEST_F(ChainFile, RoundTripsThroughJson) {
  const ChainConfig c = load(example_json());
  const json written = chain_config_to_json(c);
  EXPECT_EQ(written["feedforward"]["model"], "ff.json");  // a path stays a path
  EXPECT_EQ(chain_config_from_json(written, dir_), c);
  EXPECT_EQ(chain_config_to_json(chain_config_from_json(written, dir_)), written);

  json j = example_json();
  j["feedforward"]["model"] = models::lq_feedforward_to_json(testing::example_lq(1e-2));
  j["band_pass"] = {{"low_hz", 0}, {"high_hz", 900}, {"order", 4}, {"bypass", true}};
  j["feedback"]["source"] = "sensor";
  const ChainConfig inline_model = load(j);
  EXPECT_TRUE(chain_config_to_json(inline_model)["feedforward"]["model"].is_object());
  EXPECT_EQ(chain_config_from_json(chain_config_to_json(inline_model), dir_), inline_model);
  EXPECT_FALSE(inline_model == c);
}

TEST_F(ChainFile, ClassifiesEachKindOfChange) {
  const ChainConfig base = load(example_json());
  const auto classify = [&](auto edit) {
    ChainConfig after = base;
    edit(after);
    return classify_change(base, after);
  };
  const auto expect_class = [&](auto edit, ChangeClass kind, const std::string& key) {
    const ConfigChange change = classify(edit);
    EXPECT_EQ(change.kind, kind) << key << ": " << change_class_name(change.kind);
    ASSERT_EQ(change.differences.size(), 1u) << key;
    EXPECT_EQ(change.differences[0].key, key);
    EXPECT_EQ(change.differences[0].kind, kind);
  };
  EXPECT_EQ(classify([](ChainConfig&) {}).kind, ChangeClass::none);
  // A model read from another path but with the same content changes nothing the engine runs.
  EXPECT_EQ(classify([](ChainConfig& c) { c.feedforward->path = "copy-of-ff.json"; }).kind, ChangeClass::none);

  expect_class([](ChainConfig& c) { c.band_pass.bypass = true; }, ChangeClass::in_place, "band_pass.bypass");
  expect_class([](ChainConfig& c) { c.feedforward->bypass = true; }, ChangeClass::in_place, "feedforward.bypass");
  expect_class([](ChainConfig& c) { c.feedback->bypass = true; }, ChangeClass::in_place, "feedback.bypass");
  expect_class([](ChainConfig& c) { c.crossfade_ms = 50; }, ChangeClass::in_place, "crossfade_ms");
  expect_class([](ChainConfig& c) { c.limiter.knee = 0.7; }, ChangeClass::in_place, "limiter.knee");
  expect_class([](ChainConfig& c) { c.limiter.pinned_level = 0.99; }, ChangeClass::in_place, "limiter.pinned_level");
  expect_class([](ChainConfig& c) { c.limiter.max_pinned_ms = 50; }, ChangeClass::in_place, "limiter.max_pinned_ms");

  const auto rebuild = ChangeClass::rebuild_with_crossfade;
  expect_class([](ChainConfig& c) { c.band_pass.design.low = Hertz{50}; }, rebuild, "band_pass.low_hz");
  expect_class([](ChainConfig& c) { c.band_pass.design.high = Hertz{1000}; }, rebuild, "band_pass.high_hz");
  expect_class([](ChainConfig& c) { c.band_pass.design.order = 4; }, rebuild, "band_pass.order");
  expect_class([](ChainConfig& c) { c.feedforward->model = models::lq_feedforward_to_json(testing::example_lq(1e-2)); }, rebuild,
               "feedforward.model");
  expect_class([](ChainConfig& c) { c.feedback->source = FeedbackSource::sensor; }, rebuild, "feedback.source");
  expect_class([](ChainConfig& c) { c.feedforward.reset(); }, rebuild, "feedforward");

  expect_class([](ChainConfig& c) { c.fs = 48000; }, ChangeClass::restart, "fs");
  expect_class([](ChainConfig& c) { c.block = 128; }, ChangeClass::restart, "block");
  expect_class([](ChainConfig& c) { c.history = 1024; }, ChangeClass::restart, "history");

  // Several at once: the most demanding class, every key listed in file order.
  const ConfigChange mixed = classify([](ChainConfig& c) {
    c.limiter.knee = 0.7;
    c.band_pass.design.order = 3;
    c.block = 32;
  });
  EXPECT_EQ(mixed.kind, ChangeClass::restart);
  ASSERT_EQ(mixed.differences.size(), 3u);
  EXPECT_EQ(mixed.differences[0].key, "block");
  EXPECT_EQ(mixed.differences[1].key, "band_pass.order");
  EXPECT_EQ(mixed.differences[2].key, "limiter.knee");
}

TEST_F(ChainFile, AChainFromTheFileEqualsItsStagesEvaluatedDirectly) {
  const ChainConfig c = load(example_json());
  auto chain = make_chain(c);
  const Eigen::VectorXd program = testing::uniform(4000, 0.5, 7);
  const Eigen::VectorXd band = filtered(dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs), program);
  const Eigen::VectorXd ff = models::simulate(testing::example_lq().controller(), band);
  const Eigen::VectorXd fb = models::simulate_closed_loop(testing::chain_feedback(), ff).v;
  Eigen::VectorXd expected(fb.size());
  for (Eigen::Index k = 0; k < fb.size(); ++k) expected[k] = testing::reference_soft_limit(fb[k], 0.8);
  EXPECT_LE((run(*chain, program) - expected).cwiseAbs().maxCoeff(), 1e-12);
  const MetricsSnapshot m = chain->metrics().snapshot();
  EXPECT_EQ(m.faults, 0u);
  EXPECT_EQ(m.active_ids[1], model_id(c.feedforward->model));
  EXPECT_EQ(m.active_ids[2], model_id(c.feedback->model));
  EXPECT_NE(m.active_ids[0], 0u);
  EXPECT_NE(m.active_ids[1], m.active_ids[2]);
}

TEST_F(ChainFile, ALowCornerOfZeroIsTheLowPassAlone) {
  auto chain = make_chain(load({{"format", "panelbass.chain/1"},
                                {"fs", 3000},
                                {"band_pass", {{"low_hz", 0}, {"high_hz", 1200}, {"order", 3}}}}));
  const Eigen::VectorXd program = testing::uniform(3000, 0.5, 8);
  const Eigen::VectorXd expected = filtered(dsp::butterworth_lowpass(3, 1200.0, kFs), program);
  EXPECT_LE((run(*chain, program) - expected).cwiseAbs().maxCoeff(), 1e-12);
  // The DC of a constant passes a low-pass: a band-pass would remove it.
  auto dc = make_chain(load({{"format", "panelbass.chain/1"},
                             {"fs", 3000},
                             {"band_pass", {{"low_hz", 0}, {"high_hz", 1200}}}}));
  EXPECT_NEAR(run(*dc, Eigen::VectorXd::Constant(3000, 0.5))[2999], 0.5, 1e-9);
}

TEST_F(ChainFile, ApplyChangeSwapsModelsAndFlagsAndRefusesWhatNeedsARestart) {
  const ChainConfig before = load(example_json());
  auto chain = make_chain(before);
  const Eigen::VectorXd program = testing::uniform(640, 0.3, 9);
  run(*chain, program);

  ChainConfig after = before;
  after.feedforward->model = models::lq_feedforward_to_json(testing::example_lq(1e-2));
  after.feedback->bypass = true;
  const ConfigChange change = apply_change(*chain, before, after);
  EXPECT_EQ(change.kind, ChangeClass::rebuild_with_crossfade);
  EXPECT_TRUE(chain->feedback().bypassed());
  EXPECT_FALSE(chain->feedforward().bypassed());
  run(*chain, program);
  EXPECT_EQ(chain->metrics().snapshot().swaps, 1u);
  EXPECT_EQ(chain->metrics().snapshot().active_ids[1], model_id(after.feedforward->model));

  // Removing a slot crossfades to a pass-through stage (id 0).
  ChainConfig removed = after;
  removed.feedforward.reset();
  apply_change(*chain, after, removed);
  run(*chain, program);
  EXPECT_EQ(chain->metrics().snapshot().active_ids[1], 0u);
  EXPECT_EQ(chain->collect_retired(), 1u);  // the second controller (install() freed the first one)

  ChainConfig faster = removed;
  faster.fs = 6000;
  faster.history = 256;
  const std::string restart =
      one_line_error<std::invalid_argument>([&] { apply_change(*chain, removed, faster); });
  EXPECT_NE(restart.find("fs, history changed: the chain must be restarted"), std::string::npos) << restart;

  ChainConfig retimed = removed;
  retimed.crossfade_ms = 5;
  retimed.limiter.knee = 0.5;
  EXPECT_EQ(apply_change(*chain, removed, retimed).kind, ChangeClass::in_place);
  EXPECT_EQ(chain->options().slots.crossfade.value, 15);
  EXPECT_EQ(chain->options().limiter.knee, 0.5);
  ChainConfig broken = retimed;
  broken.limiter.knee = 1.5;
  EXPECT_THROW(apply_change(*chain, retimed, broken), std::invalid_argument);
  EXPECT_EQ(chain->options().limiter.knee, 0.5) << "a refused change changes nothing";

  ChainConfig other_rate = before;
  other_rate.fs = 6000;
  const std::string mismatch =
      one_line_error<std::invalid_argument>([&] { apply_change(*chain, other_rate, other_rate); });
  EXPECT_NE(mismatch.find("the chain runs at fs = 3000 Hz"), std::string::npos) << mismatch;
  EXPECT_EQ(chain->metrics().snapshot().faults, 0u);
}

TEST_F(ChainFile, ABypassedStartAndALimiterChangeActFromTheirFirstSample) {
  // Band-pass bypassed from the start, no controllers: drive = soft_limit(program) from sample 0.
  ChainConfig before = load({{"format", "panelbass.chain/1"}, {"fs", 3000}, {"block", 64}});
  before.band_pass.bypass = true;
  auto chain = make_chain(before);
  const Eigen::VectorXd program = testing::uniform(64, 1.5, 12);
  std::vector<double> drive(64);
  chain->process_block(std::span<const double>(program.data(), 64), drive);
  for (int k = 0; k < 64; ++k) ASSERT_DOUBLE_EQ(drive[k], testing::reference_soft_limit(program[k], 0.8)) << k;
  ChainConfig softer = before;
  softer.limiter.knee = 0.5;
  apply_change(*chain, before, softer);
  chain->process_block(std::span<const double>(program.data(), 64), drive);
  for (int k = 0; k < 64; ++k) ASSERT_DOUBLE_EQ(drive[k], testing::reference_soft_limit(program[k], 0.5)) << k;
}

TEST_F(ChainFile, ANewBandPassAppliedWhileTheVirtualBackendPlaysTakesOverWithoutAFault) {
  // Band-pass only; 3 s of program played in real time, the band-pass changed after a few blocks.
  const ChainConfig before = load({{"format", "panelbass.chain/1"}, {"fs", 3000}, {"block", 64}, {"crossfade_ms", 20}});
  ChainConfig after = before;
  after.band_pass.design = {Hertz{100.0}, Hertz{600.0}, 3};
  ASSERT_EQ(classify_change(before, after).kind, ChangeClass::rebuild_with_crossfade);

  auto chain = make_chain(before);
  const Eigen::VectorXd program = testing::uniform(9000, 0.3, 10);
  Eigen::VectorXd drive = Eigen::VectorXd::Zero(program.size());
  std::atomic<long> swap_block{-1};
  VirtualBackendOptions options;
  options.block = Samples{64};
  options.pacing = Pacing::real_time;
  options.program.assign(program.data(), program.data() + program.size());
  options.loop = false;
  options.plant = models::plant_preset("linear");
  Chain* running = chain.get();
  options.on_block = [&drive, &swap_block, running](const BlockView& b) {
    // Allocation-free: copies into the vector sized above, notes the first block after the swap.
    const auto pos = static_cast<Eigen::Index>(b.index * 64);
    for (std::size_t k = 0; k < b.drive.size(); ++k) drive[pos + static_cast<Eigen::Index>(k)] = b.drive[k];
    if (swap_block.load(std::memory_order_relaxed) < 0 && running->metrics().swaps() > 0) {
      swap_block.store(static_cast<long>(b.index), std::memory_order_relaxed);
    }
  };
  VirtualBackend backend(*chain, std::move(options));
  backend.start();
  while (backend.blocks() < 10 && !backend.finished()) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  apply_change(*chain, before, after);
  backend.wait();
  chain->collect_retired();

  const MetricsSnapshot m = chain->metrics().snapshot();
  EXPECT_EQ(m.faults, 0u);
  EXPECT_FALSE(m.in_fault);
  EXPECT_EQ(m.swaps, 1u);
  EXPECT_EQ(m.active_ids[0], model_id(json{{"kind", "band_pass"}, {"low_hz", 100.0}, {"high_hz", 600.0}, {"order", 3}}));
  const long swapped = swap_block.load();
  ASSERT_GE(swapped, 0);
  // Before the swap: the old band-pass. Well after it (the crossfade's longest time, 4 × 60 samples, and
  // 1500 samples for the warm-up's state to decay): the new one, as if it had always run.
  const auto swap_at = static_cast<Eigen::Index>(swapped * 64);
  const Eigen::VectorXd old_band = filtered(dsp::butterworth_bandpass(2, 20.0, 1200.0, kFs), program);
  const Eigen::VectorXd new_band = filtered(dsp::butterworth_bandpass(3, 100.0, 600.0, kFs), program);
  EXPECT_LE((drive.head(swap_at) - old_band.head(swap_at)).cwiseAbs().maxCoeff(), 1e-12);
  const Eigen::Index settled = swap_at + 4 * 60 + 1500;
  ASSERT_LT(settled + 1000, program.size()) << "the change came too late to be checked";
  const Eigen::Index n = program.size() - settled;
  EXPECT_LE((drive.tail(n) - new_band.tail(n)).cwiseAbs().maxCoeff(), 1e-9);
}

}  // namespace
}  // namespace panelbass::engine

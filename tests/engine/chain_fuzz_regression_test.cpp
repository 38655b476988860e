// Inputs that fuzz/chain_json_fuzz.cpp found to break a chain file's contract (chain_file.h: every value is
// validated, and what cannot run is a ConfigError naming the key path), kept byte for byte.
//
// LinearModelTooLongToRealize…: a linear model's loader accepts a delay nk up to 384000·60 samples, but the
// LinearStage (then the engine's, now the tests', tests/support/model_stages.h) realizes the model as a dense state space of order max(na, nb + nk) (models::realize:
// n×n long-double matrices, a Jacobi SVD, a complex LU per frequency; then an n×n product per sample).
// nk = 102 took 15 s in the fuzzer; nk = 100000 asked for 160 GB, an out-of-memory crash. The stage now
// refuses more than kMaxStageStates states when it is made; a chain now refuses a linear model in any slot
// (a plant model: the model-kind registry gives it none) before realising anything.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "engine/chain_file.h"
#include "engine/stage.h"
#include "models/linear/linear_model.h"
#include "models/io/config_error.h"
#include "tests/support/expect_error.h"
#include "tests/support/model_stages.h"

namespace panelbass::engine {
namespace {

// slow-unit-0b8fbe7d9dbf2282a0d00646f3bc3dbeb729eac3 (chain_json_fuzz), with "nk" as a parameter.
std::string chain_with_delay(long nk) {
  return R"({"format":"panelbass.chain/1","fs":3000,"limiter":{"knee":0.8,"pinned_level":1.0,"max_pinned_ms":100},)"
         R"("feedforward":{"model":{"format":"panelbass.model/1","fs":3000.0,"kind":"linear","meta":{},"method":"oe",)"
         R"("params":{"a":[-0.85,0.06674801813335],"b":[0.05605159492],"nk":)" +
         std::to_string(nk) +
         R"(},"scaling":{"u_offset":0.0077277823719732704,"u_scale":0.5071476096141433,)"
         R"("y_offset":-0.002152072150852268,"y_scale":2.210257906366087}}}})";
}

// crash-5c0de9f177ec11473f0c8ef968627262bcc9100a: a chain without "band_pass" at fs = 300 Hz was accepted with
// the default 1200 Hz corner above Nyquist; its own JSON form (chain_config_to_json) was then refused.
TEST(ChainFuzzRegressionTest, DefaultBandPassMustSuitTheRate) {
  const nlohmann::json chain = nlohmann::json::parse(R"({"format":"panelbass.chain/1","fs":300})");
  const std::string message = testing_support::one_line_error<models::ConfigError>(
      [&] { (void)chain_config_from_json(chain, std::filesystem::temp_directory_path()); });
  EXPECT_NE(message.find("chain.band_pass.high_hz: must be within (0, fs/2 = 150) Hz, got 1200"), std::string::npos)
      << message;
}

// A linear model is a plant model, which no slot runs (the model-kind registry): refused by its kind before anything
// is realised, so the long delay costs nothing.
TEST(ChainFuzzRegressionTest, LinearModelTooLongToRealizeIsAConfigErrorNamingTheSlot) {
  for (const long nk : {102L, 100000L, 23040000L}) {
    const nlohmann::json chain = nlohmann::json::parse(chain_with_delay(nk));
    const std::string message = testing_support::one_line_error<models::ConfigError>(
        [&] { (void)chain_config_from_json(chain, std::filesystem::temp_directory_path()); });
    EXPECT_NE(message.find("chain.feedforward.model: the model is a linear plant model (kind linear): the feedforward "
                           "slot takes lq_feedforward or mirror_filter"),
              std::string::npos)
        << message;
  }
}

TEST(ChainFuzzRegressionTest, ALinearModelAtTheStateLimitStillRunsAsTheModelSimulates) {
  // nk = 63: 64 states, exactly the limit. The stage's response to a pulse equals the model's own simulation.
  const nlohmann::json model = nlohmann::json::parse(chain_with_delay(63))["feedforward"]["model"];
  const models::LinearModel linear = models::linear_model_from_json(model);
  LinearStage stage(linear);
  stage.prepare({.fs = 3000.0, .max_block = 64});
  Eigen::VectorXd u = Eigen::VectorXd::Zero(200);
  u(3) = 0.5;
  const Eigen::VectorXd expected = linear.simulate(u);
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    EXPECT_NEAR(stage.process(u(k)), expected(k), 1e-9) << "sample " << k;
  }
  EXPECT_GT(std::abs(expected(3 + 63) - expected(3 + 62)), 1e-3) << "the pulse arrives after its delay";
}

}  // namespace
}  // namespace panelbass::engine

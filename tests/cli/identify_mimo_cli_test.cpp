// `panelbass identify mimo` and `validate` on a small simulated periodic MIMO record (2 inputs, 2 outputs,
// 4 states, no noise): the model found reproduces the test record's steady state, validate reports per-output
// RMSEs and J by the FSM protocol, and a missing column is named.

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "tests/support/cli_runner.h"
#include "tests/support/mimo_systems.h"

namespace panelbass {
namespace {

using namespace testing_support;

class CliIdentifyMimo : public CliTest {
 protected:
  /// A periodic CSV of `realizations` × 2 periods × 256 samples of the known system, inputs from `seed`.
  fs::path record(const std::string& name, int realizations, std::uint64_t seed) {
    const models::MimoStateSpace truth = mimo_system({{0.9, 0.4}, {0.8, 1.7}}, 2, 2, 9);
    std::string text = "realization,period,n,u1,u2,y1,y2\n";
    char line[256];
    for (int r = 0; r < realizations; ++r) {
      const Eigen::MatrixXd u = gaussian_matrix(256, 2, seed + static_cast<std::uint64_t>(r));
      const Eigen::MatrixXd y = steady_state_output(truth, u, 30);
      for (int q = 1; q <= 2; ++q) {
        for (Eigen::Index n = 0; n < u.rows(); ++n) {
          std::snprintf(line, sizeof line, "%d,%d,%ld,%.17g,%.17g,%.17g,%.17g\n", r + 1, q, static_cast<long>(n), u(n, 0),
                        u(n, 1), y(n, 0), y(n, 1));
          text += line;
        }
      }
    }
    return file(name, text);
  }
};

TEST_F(CliIdentifyMimo, IdentifiesAndValidatesAPeriodicMimoRecord) {
  const fs::path train = record("train.csv", 3, 100), test = record("test.csv", 2, 200), model = dir_ / "m.json";
  const json r = expect_result(run("identify mimo --data " + quoted(train) + " --fs 1000 --inputs u1,u2 --outputs y1,y2 "
                                   "--order 4 --taps 60 --max-iter 30 --out " + quoted(model)));
  EXPECT_EQ(r["order"], 4);
  EXPECT_LT(r["J_val_pct"].get<double>(), 1e-6) << "noise-free data of an order-4 system";
  EXPECT_LE(r["J_val_pct"].get<double>(), r["kung_J_val_pct"].get<double>());
  const json v = expect_result(run("validate --model " + quoted(model) + " --data " + quoted(test) + " --init 10"));
  EXPECT_EQ(v["kind"], "mimo");
  EXPECT_EQ(v["realizations"], 2);
  EXPECT_EQ(v["periods"], 2);
  EXPECT_LT(v["J_sim_pct"].get<double>(), 1e-6);
  ASSERT_TRUE(v["rmse_per_output"].contains("y1"));
  ASSERT_TRUE(v["rmse_per_output"].contains("y2"));
  EXPECT_NEAR(v["rmse"].get<double>(),
              0.5 * (v["rmse_per_output"]["y1"].get<double>() + v["rmse_per_output"]["y2"].get<double>()), 1e-15);
}

TEST_F(CliIdentifyMimo, AMissingColumnIsNamed) {
  const fs::path train = record("train.csv", 2, 100);
  const RunResult r = run("identify mimo --data " + quoted(train) + " --fs 1000 --inputs u1,u2 --outputs y1,y3 --order 2 "
                          "--out " + quoted(dir_ / "m.json"));
  expect_failure(r);
  EXPECT_NE(r.err.find("no column \"y3\""), std::string::npos) << r.err;
}

}  // namespace
}  // namespace panelbass

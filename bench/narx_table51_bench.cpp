// Thesis table 5.1: a NN 3-5-1 (inputs y(k−1), y(k−2), u(k)) fitted to the second-order system [5Q]
// y(k) = 2A·cos(23°)·y(k−1) − A²·y(k−2) + b·u(k) under uniform white noise, for poles ever closer to the
// unit circle. The thesis's protocol: PEM with L = 1, α = 0.1 (10 iterations) and L = N, α = 0.01 (20),
// then OEM_s with L = N, α = 0.01 (20). Added: OEM_s and OEM_d with Levenberg–Marquardt from the same
// PEM model, and the default chain (PEM then OEM_d, both LM) from the initial weights.
//
// Usage: narx_table51_bench [N = 5000] [LM iterations = 200] (--help). Prints a markdown table (J in percent,
// simulation J [2A] over k ≥ 4 unless the column says pred).
#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "dsp/excitation.h"
#include "models/narx/narx_training.h"
#include "models/validation/performance.h"

namespace {

using namespace panelbass;
using namespace panelbass::models;

/// [5Q] poles A·e^{±j23°}; b such that max |y| = 1 (the thesis's scaled units).
Eigen::VectorXd second_order(const Eigen::VectorXd& u, double A) {
  const double c = 2.0 * A * std::cos(23.0 * std::numbers::pi / 180.0);
  Eigen::VectorXd y(u.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    double s = u[k];
    if (k >= 1) s += c * y[k - 1];
    if (k >= 2) s -= A * A * y[k - 2];
    y[k] = s;
  }
  return y / y.cwiseAbs().maxCoeff();
}

TrainingOptions sd_options(TrainingMode mode, double alpha, Eigen::Index batch, int iterations) {
  TrainingOptions o;
  o.modes = {mode};
  o.optimizer = Optimizer::sd;
  o.step = alpha;
  o.batch = batch;
  o.max_iterations = iterations;
  o.early_stopping = false;
  return o;
}

TrainingOptions lm_options(std::vector<TrainingMode> modes, int iterations) {
  TrainingOptions o;
  o.modes = std::move(modes);
  o.optimizer = Optimizer::lm;
  o.max_iterations = iterations;
  o.early_stopping = false;
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Thesis table 5.1: NN 3-5-1 on [5Q] for poles ever closer to the unit circle (a markdown table)"};
  long n = 5000;
  int lm_iterations = 200;
  app.add_option("samples", n, "Samples N of the estimation record")->check(CLI::Range(100L, 100000000L))->capture_default_str();
  app.add_option("lm-iterations", lm_iterations, "Levenberg-Marquardt iterations at most per mode")
      ->check(CLI::Range(1, 100000))->capture_default_str();
  app.footer("Example:\n  build/bin/narx_table51_bench 5000 200");
  CLI11_PARSE(app, argc, argv);
  const Eigen::Index skip = 4;  // 2·(na + nb)
  struct Row {
    double A;
    const char* thesis;
  };
  const Row rows[] = {{0.8, "0.2"}, {0.9, "0.4"}, {0.95, "0.8"}, {0.98, "2.8"}, {0.99, "8.0"}, {0.999, "130"}};

  std::printf("Table 5.1, NN 3-5-1, N = %ld, uniform white noise in ±1, LM up to %d iterations\n\n",
              static_cast<long>(n), lm_iterations);
  std::printf("| A | thesis J_OEMs | J_PEM pred | J_PEM sim | J_OEM-s (sd, thesis) | J_OEM-s (LM) | J_OEM-d (LM) | "
              "J_PEM→OEM-d (LM, LM) | s |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const Row& row : rows) {
    const auto started = std::chrono::steady_clock::now();
    const Eigen::VectorXd u = dsp::uniform_noise(static_cast<std::size_t>(n), 1.0, 7);
    const Eigen::VectorXd y = second_order(u, row.A);
    NarxStructure structure;
    structure.na = 2;
    structure.nb = 0;
    structure.hidden = {5};
    NarxModel start = NarxModel::with_structure(structure, Scaling{}, 1.0);
    start.net.initialize(1.0, 11);
    const Eigen::VectorXd none;

    // the thesis's PEM steps
    NarxModel pem = train_narx(start, u, y, none, none, sd_options(TrainingMode::pem, 0.1, 1, 10)).model;
    pem = train_narx(pem, u, y, none, none, sd_options(TrainingMode::pem, 0.01, 0, 20)).model;
    const double j_pem_pred = j_percent(pem.predict_scaled(u, y), y, skip);
    const double j_pem_sim = j_percent(pem.simulate_scaled(u), y, skip);
    // from that PEM model: the thesis's OEM_s, OEM_s and OEM_d with LM
    const double j_oem_s_sd =
        train_narx(pem, u, y, none, none, sd_options(TrainingMode::oem_s, 0.01, 0, 20)).history.back().j_est_pct;
    const double j_oem_s_lm =
        train_narx(pem, u, y, none, none, lm_options({TrainingMode::oem_s}, lm_iterations)).history.back().j_est_pct;
    const double j_oem_d_lm =
        train_narx(pem, u, y, none, none, lm_options({TrainingMode::oem_d}, lm_iterations)).history.back().j_est_pct;
    // the default chain from the initial weights
    const double j_chain =
        train_narx(start, u, y, none, none, lm_options({TrainingMode::pem, TrainingMode::oem_d}, lm_iterations / 2))
            .history.back()
            .j_est_pct;
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    std::printf("| %.3f | %s | %.3g | %.3g | %.3g | %.3g | %.3g | %.3g | %.2f |\n", row.A, row.thesis, j_pem_pred,
                j_pem_sim, j_oem_s_sd, j_oem_s_lm, j_oem_d_lm, j_chain, seconds);
  }
  return 0;
}

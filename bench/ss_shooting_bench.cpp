// The neural state-space model's L-BFGS from one start two ways, side by side (issue 59): polish_ss (windows
// started by the encoder, θ alone) and train_ss_shooting (multiple shooting: every window's initial state free,
// continuity and the encoder's reading as penalties, θ and the states together). Both keep the iterate of the
// lowest validation J — the encoder from the first --init validation samples, then free run, the J `identify
// ss` reports. Prints each one's best J_val and the seconds to it; --out logs every iteration of both.
//
// Usage: ss_shooting_bench --start ss.json --data rec.csv --est-rows N [--window 100 --penalty 1 --iterations 200]
#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "dsp/data_file.h"
#include "models/state_space_nn/ss_multiple_shooting.h"
#include "models/state_space_nn/ss_training.h"

int main(int argc, char** argv) {
  using namespace panelbass;
  CLI::App app{"ss L-BFGS: encoder-started windows against multiple shooting, from one start"};
  std::string start_path, data, out;
  long est_rows = 0, init = 50, window = 100;
  int iterations = 200;
  double penalty = 1.0, fs = 1.0;
  app.add_option("--start", start_path, "ss model file to start from")->required();
  app.add_option("--data", data, "CSV with columns u,y")->required();
  app.add_option("--fs", fs, "Sample rate")->capture_default_str();
  app.add_option("--est-rows", est_rows, "Rows that estimate; the rest validate")->required();
  app.add_option("--window", window)->capture_default_str();
  app.add_option("--penalty", penalty, "multiple shooting's ρ")->capture_default_str();
  app.add_option("--iterations", iterations)->capture_default_str();
  app.add_option("--init", init)->capture_default_str();
  app.add_option("--out", out, "CSV log of every iteration of both");
  CLI11_PARSE(app, argc, argv);

  std::ifstream file(start_path);
  const models::SsModel start = models::ss_model_from_json(nlohmann::json::parse(file));
  const dsp::Record record = dsp::read_data_file(data, {"u", "y"}, fs);
  const Eigen::VectorXd& u = record.columns[0];
  const Eigen::VectorXd& y = record.columns[1];
  if (est_rows <= 0 || est_rows >= u.size()) {
    std::fprintf(stderr, "ss_shooting_bench: --est-rows must be within (0, %ld)\n", static_cast<long>(u.size()));
    return 2;
  }
  const Eigen::VectorXd ue = u.head(est_rows), ye = y.head(est_rows);
  const Eigen::VectorXd uv = u.tail(u.size() - est_rows), yv = y.tail(u.size() - est_rows);

  std::ofstream log;
  if (!out.empty()) {
    log.open(out);
    log << "run,iteration,seconds,loss,J_val_pct\n";
  }
  const auto logger = [&](const char* name) {
    return [&log, &out, name](const models::SsTrainingRecord& r) {
      if (!out.empty()) log << name << ',' << r.epoch << ',' << r.seconds << ',' << r.loss << ',' << r.j_val_pct << '\n';
      return true;
    };
  };
  const auto best_seconds = [](const models::SsTraining& t) {
    for (const auto& r : t.history) {
      if (r.epoch == t.best_epoch) return r.seconds;
    }
    return 0.0;
  };
  models::SsPolishOptions polish;
  polish.window = window;
  polish.iterations = iterations;
  polish.init = init;
  polish.progress = logger("encoder-windows");
  const models::SsTraining single = models::polish_ss(start, ue, ye, uv, yv, polish);
  models::SsShootingOptions shooting;
  shooting.window = window;
  shooting.penalty = penalty;
  shooting.iterations = iterations;
  shooting.init = init;
  shooting.progress = logger("multiple-shooting");
  const models::SsTraining multiple = models::train_ss_shooting(start, ue, ye, uv, yv, shooting);
  std::printf("start J_val %.6g %%\n", single.history.front().j_val_pct);
  std::printf("encoder-windows L-BFGS: best J_val %.6g %% at iteration %d (%.2f s) of %zu, %.2f s in all\n",
              single.j_val_pct, single.best_epoch, best_seconds(single), single.history.size() - 1, single.seconds);
  std::printf("multiple-shooting L-BFGS: best J_val %.6g %% at iteration %d (%.2f s) of %zu, %.2f s in all\n",
              multiple.j_val_pct, multiple.best_epoch, best_seconds(multiple), multiple.history.size() - 1,
              multiple.seconds);
  return 0;
}

// One NARX training recipe of `identify narx` on a record, its validation J logged per iteration with the
// seconds since the start, in the peer's CSV form (bench/peers/narx_torch.py): run,epoch,seconds,J_val_pct, and
// the mode of the iteration.
// For bench/narx_recipes.sh, which sets it beside the PyTorch recipes. The data and the J are the CLI's: the
// first --est-rows rows estimate, the rest validate, scaled by the estimation part; the first --init measured
// outputs set the state of every simulation and J runs from there (identify narx's protocol, its history's J).
// --restarts R trains from seeds seed … seed + R − 1 one after the other (the clock runs on) and keeps the lowest
// final J_val, as identify narx --restarts.
//
// Usage: narx_recipe_bench --data FILE --fs FS --est-rows N [--train pem,oem-ms,oem-d ...] --out LOG.csv
#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "dsp/data_file.h"
#include "models/narx/narx_training.h"
#include "models/validation/performance.h"

int main(int argc, char** argv) {
  using namespace panelbass;
  CLI::App app{"A NARX training recipe's validation J per iteration, with seconds (bench/narx_recipes.sh)"};
  std::string data, out, train = "pem,oem-d", name;
  double fs = 1.0, weight_decay = 0.0;
  long est_rows = 0, init = 50;
  int na = 8, nb = 8, max_iterations = 100, restarts = 1, patience = 20;
  int pem_max_iterations = -1;
  double pem_min_progress = models::kDefaultPemMinProgress;
  std::vector<int> hidden{17};
  std::uint64_t seed = 1;
  models::MultipleShootingOptions ms;
  app.add_option("--data", data, "CSV with columns u,y")->required();
  app.add_option("--fs", fs, "Sample rate")->capture_default_str();
  app.add_option("--est-rows", est_rows, "Rows that estimate; the rest validate")->required();
  app.add_option("--na", na)->capture_default_str();
  app.add_option("--nb", nb)->capture_default_str();
  app.add_option("--hidden", hidden)->delimiter(',');
  app.add_option("--train", train, "Modes in order, as identify narx --train")->capture_default_str();
  app.add_option("--max-iter", max_iterations)->capture_default_str();
  app.add_option("--pem-max-iter", pem_max_iterations, "The pem mode's own limit (-1: --max-iter)")->capture_default_str();
  app.add_option("--patience", patience)->capture_default_str();
  app.add_option("--pem-min-progress", pem_min_progress,
                 "pem also stops once its best J_val fell by less than this fraction over 10 iterations (0: off)")
      ->capture_default_str();
  app.add_option("--seed", seed)->capture_default_str();
  app.add_option("--restarts", restarts)->capture_default_str();
  app.add_option("--weight-decay", weight_decay)->capture_default_str();
  std::string evidence_decay = "off";
  app.add_option("--evidence-decay", evidence_decay,
                 "Re-estimate the weight decay each LM iteration by MacKay's evidence: off, all (modes), oem (after pem)")
      ->capture_default_str();
  app.add_option("--init", init, "Measured outputs setting the state (at most a tenth of the shorter part)")
      ->capture_default_str();
  app.add_option("--ms-window", ms.window)->capture_default_str();
  app.add_option("--ms-penalty", ms.penalty)->capture_default_str();
  app.add_option("--ms-penalty-growth", ms.penalty_growth)->capture_default_str();
  app.add_option("--ms-penalty-max", ms.penalty_max)->capture_default_str();
  app.add_option("--name", name, "Run name in the log (default: the --train list)");
  app.add_option("--out", out, "CSV log")->required();
  CLI11_PARSE(app, argc, argv);

  const dsp::Record record = dsp::read_data_file(data, {"u", "y"}, fs);
  const Eigen::VectorXd& u = record.columns[0];
  const Eigen::VectorXd& y = record.columns[1];
  if (est_rows <= 0 || est_rows >= u.size()) {
    std::fprintf(stderr, "narx_recipe_bench: --est-rows must be within (0, %ld)\n", static_cast<long>(u.size()));
    return 2;
  }
  const Eigen::Index n_val = u.size() - est_rows;
  const Eigen::VectorXd u_est = u.head(est_rows), y_est = y.head(est_rows);
  const Eigen::VectorXd u_val = u.tail(n_val), y_val = y.tail(n_val);
  const models::Scaling scaling = models::scaling_from_data(u_est, y_est);
  const Eigen::VectorXd us = scaling.scale_u(u_est), ys = scaling.scale_y(y_est);
  const Eigen::VectorXd uv = scaling.scale_u(u_val), yv = scaling.scale_y(y_val);

  models::TrainingOptions options;
  options.modes.clear();
  for (std::size_t start = 0; start <= train.size();) {
    const std::size_t comma = train.find(',', start);
    options.modes.push_back(models::parse_training_mode(train.substr(start, comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  options.max_iterations = max_iterations;
  options.pem_max_iterations = pem_max_iterations;
  options.patience = patience;
  options.pem_min_progress = pem_min_progress;
  options.weight_decay = weight_decay;
  options.evidence_decay = models::parse_evidence_decay(evidence_decay);
  options.init = std::min<Eigen::Index>(init, std::min<Eigen::Index>(est_rows, n_val) / 10);
  options.multiple_shooting = ms;
  if (name.empty()) name = train;

  std::ofstream log(out);
  log << "run,epoch,seconds,J_val_pct,mode,weight_decay\n";
  const auto started = std::chrono::steady_clock::now();
  const auto seconds = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  };
  int epoch = 0;
  options.progress = [&](const models::TrainingRecord& r) {
    log << name << ',' << epoch++ << ',' << seconds() << ',' << r.j_val_pct << ',' << models::to_string(r.mode) << ','
        << r.weight_decay << '\n';
  };
  double best = std::numeric_limits<double>::infinity();
  for (int r = 0; r < restarts; ++r) {
    models::NarxModel model = models::NarxModel::with_structure({na, nb, 0, hidden}, scaling, fs);
    model.net.initialize(1.0, seed + static_cast<std::uint64_t>(r));
    const models::TrainingResult result = models::train_narx(model, us, ys, uv, yv, options);
    const double j = models::j_percent(result.model.simulate_scaled(uv, yv, options.init), yv, options.init);
    best = std::min(best, j);
    std::fprintf(stderr, "%s seed %lu: J_val %.6g %% after %d iterations, %.2f s\n", name.c_str(),
                 static_cast<unsigned long>(seed + r), j, result.iterations, seconds());
  }
  std::printf("%s best_J_val_pct %.6g seconds %.3f\n", name.c_str(), best, seconds());
  return 0;
}

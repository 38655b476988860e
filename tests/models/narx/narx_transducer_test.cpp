// The NARX issue's transducer case: on `panel-exciter`, 5 000 estimation + 5 000 validation samples of
// uniform white noise, an NN 17-17-1 (na = nb = 8) trained pem then oem-d with Levenberg–Marquardt
// beats the best linear model (Zhu's method, order chosen by the scan) by at least 30 % in validation J.

#include <gtest/gtest.h>

#include "dsp/excitation.h"
#include "models/linear/linear_identification.h"
#include "models/narx/narx_training.h"
#include "models/validation/performance.h"
#include "models/plant/plant_presets.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::models {
namespace {

TEST(NarxTransducer, NeuralModelBeatsTheBestLinearModelByThirtyPercent) {
  const Eigen::VectorXd u = dsp::uniform_noise(10000, 1.0, 11);
  const Eigen::VectorXd y = simulate(plant_preset("panel-exciter"), u, 12).y;
  const Eigen::VectorXd u_est = u.head(5000), y_est = y.head(5000), u_val = u.tail(5000), y_val = y.tail(5000);
  constexpr Eigen::Index kInit = 50;  // both judged alike: 50 measured outputs set the state, then free run

  LinearIdentificationSpec linear;
  linear.method = LinearMethod::zhu;
  linear.scan_from = 1;
  linear.scan_to = 12;
  linear.fs = 3000.0;
  linear.init = kInit;
  const double j_linear = identify_linear(u_est, y_est, u_val, y_val, linear).j_val_pct;

  const Scaling scaling = scaling_from_data(u_est, y_est);
  NarxModel initial = NarxModel::with_structure({8, 8, 0, {17}}, scaling, 3000.0);
  initial.net.initialize(1.0, 1);
  TrainingOptions options;
  options.modes = {TrainingMode::pem, TrainingMode::oem_d};
  options.optimizer = Optimizer::lm;
  options.max_iterations = 30;
  const NarxModel nn = train_narx(initial, scaling.scale_u(u_est), scaling.scale_y(y_est), scaling.scale_u(u_val),
                                  scaling.scale_y(y_val), options)
                           .model;
  const double j_nn = j_percent(nn.simulate(u_val, y_val, kInit), y_val, kInit);
  RecordProperty("J_val_linear_pct", std::to_string(j_linear));
  RecordProperty("J_val_narx_pct", std::to_string(j_nn));
  EXPECT_LT(j_nn, 0.7 * j_linear) << "linear " << j_linear << " %, NARX " << j_nn << " %";
}

}  // namespace
}  // namespace panelbass::models

#include "models/linear/frequency_response.h"

namespace panelbass::models {

Eigen::VectorXcd frequency_response(const StateSpace& ss, const Eigen::VectorXd& frequency_hz, double fs) {
  Eigen::VectorXcd h(frequency_hz.size());
  for (Eigen::Index k = 0; k < frequency_hz.size(); ++k) h[k] = response(ss, frequency_hz[k], fs);
  return h;
}

Eigen::VectorXcd frequency_response(const TransferFunction& tf, const Eigen::VectorXd& frequency_hz, double fs) {
  Eigen::VectorXcd h(frequency_hz.size());
  for (Eigen::Index k = 0; k < frequency_hz.size(); ++k) h[k] = tf.response(frequency_hz[k], fs);
  return h;
}

}  // namespace panelbass::models

#pragma once
// Small vectors written out in a test.

#include <Eigen/Core>
#include <initializer_list>

namespace panelbass::testing_support {

/// The values `v` as an Eigen vector, in order.
inline Eigen::VectorXd vec(std::initializer_list<double> v) {
  Eigen::VectorXd x(static_cast<Eigen::Index>(v.size()));
  Eigen::Index i = 0;
  for (double d : v) x[i++] = d;
  return x;
}

}  // namespace panelbass::testing_support

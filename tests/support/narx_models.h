#pragma once
// Small NARX models written by hand, whose behaviour the tests can work out in closed form.

#include "models/narx/narx_model.h"

namespace panelbass::testing_support {

/// y(k) = w·tanh(a·y(k−1) + b·u(k) + c) + d in scaled units: one node, na = 1, nb = 0, nk = 0.
inline models::NarxModel one_node_narx(double a, double b, double c, double w, double d,
                                       const models::Scaling& scaling, double fs) {
  models::NarxStructure s;
  s.na = 1;
  s.nb = 0;
  s.nk = 0;
  s.hidden = {1};
  models::NarxModel m = models::NarxModel::with_structure(s, scaling, fs);
  m.net.parameters() << a, b, c, w, d;  // hidden row [y(k−1), u(k)], its bias, output weight, output bias
  return m;
}

}  // namespace panelbass::testing_support

// Diagnosis of block structure and the newer physics terms: a static nonlinearity between two filters
// (Wiener–Hammerstein) and after the dynamics (Wiener) is named with where it sits and its shape, on systems
// built here from two known filters and a known static function; the features of nonlinear damping and of
// an asymmetric force factor carry nothing a linear model of their state already explains.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "models/diagnosis/diagnosis.h"
#include "tests/support/linear_systems.h"

namespace panelbass::models {
namespace {

using testing_support::gaussian;

constexpr double kStructureFs = 1000.0;
constexpr Eigen::Index kEst = 8000, kVal = 6000;

TransferFunction two_pole(double a1, double a2) {
  TransferFunction tf;
  tf.a = Eigen::Vector2d(a1, a2);
  tf.b = Eigen::VectorXd::Constant(1, 1.0 + a1 + a2);  // unit DC gain
  tf.nk = 0;
  return tf;
}

// A diode-like static function: the identity up to `knee`, a tenth of the slope beyond it (one side only).
Eigen::VectorXd diode(const Eigen::VectorXd& x, double knee) {
  return x.unaryExpr([knee](double v) { return v > knee ? knee + 0.1 * (v - knee) : v; });
}

struct Records {
  Eigen::VectorXd u_est, y_est, u_val, y_val;
};

// u white, x = L1·u, w = f(x), y = L2·w (or w alone without L2) plus a little white noise.
Records block_records(bool with_back_filter, std::uint64_t seed) {
  const Eigen::VectorXd u = gaussian(kEst + kVal, 1.0, seed);
  const Eigen::VectorXd x = filter_through(two_pole(-1.2, 0.5), u);
  const double rms = std::sqrt(x.squaredNorm() / static_cast<double>(x.size()));
  const Eigen::VectorXd w = diode(x / rms, 0.8);
  Eigen::VectorXd y = with_back_filter ? filter_through(two_pole(-0.4, 0.6), w) : w;
  y += gaussian(y.size(), 0.002, seed + 1);
  return {u.head(kEst), y.head(kEst), u.tail(kVal), y.tail(kVal)};
}

DiagnosisOptions small_scan(int order) {
  DiagnosisOptions o;
  o.scan_from = order;
  o.scan_to = order;
  o.max_findings = 1;
  return o;
}

TEST(DiagnosisStructure, ADiodeBetweenTwoFiltersIsASaturatingStaticNonlinearityBetweenThem) {
  const Records r = block_records(true, 3);
  const Diagnosis d = diagnose(r.u_est, r.y_est, r.u_val, r.y_val, kStructureFs, std::nullopt, small_scan(4));
  ASSERT_FALSE(d.findings.empty()) << diagnosis_to_json(d)["rounds"].dump(1);
  const Finding& f = d.findings.front();
  EXPECT_EQ(to_string(f.effect), "static_nonlinearity") << f.explanation;
  EXPECT_EQ(f.parameters.value("position", ""), "between") << f.parameters.dump();
  EXPECT_EQ(f.parameters.value("shape", ""), "saturating") << f.parameters.dump();
  // Most of what the linear model misses is the diode's.
  EXPECT_LT(f.j_val_after_pct, 0.3 * f.j_val_before_pct);
}

TEST(DiagnosisStructure, ADiodeAfterTheDynamicsIsAWienerStaticNonlinearity) {
  const Records r = block_records(false, 5);
  const Diagnosis d = diagnose(r.u_est, r.y_est, r.u_val, r.y_val, kStructureFs, std::nullopt, small_scan(2));
  ASSERT_FALSE(d.findings.empty()) << diagnosis_to_json(d)["rounds"].dump(1);
  const Finding& f = d.findings.front();
  EXPECT_EQ(to_string(f.effect), "static_nonlinearity") << f.explanation;
  EXPECT_EQ(f.parameters.value("position", ""), "output") << f.parameters.dump();
  EXPECT_EQ(f.parameters.value("structure", ""), "Wiener");
  EXPECT_EQ(f.parameters.value("shape", ""), "saturating") << f.parameters.dump();
  EXPECT_NE(f.explanation.find("Wiener structure"), std::string::npos) << f.explanation;
}

// The features are orthogonal to the state's linear part on the record they are built on (so a linear
// model of the state cannot already explain them), and to the velocity for the damping's v³.
TEST(DiagnosisStructure, NewFeaturesAddOnlyWhatALinearModelOfTheStateCannot) {
  const Eigen::VectorXd u = gaussian(4000, 1.0, 7);
  const Eigen::VectorXd y = filter_through(two_pole(-1.2, 0.5), u);
  const StateSignals s = state_signals(u, y, kStructureFs);
  for (Effect e : {Effect::nonlinear_damping, Effect::asymmetric_force_factor}) {
    DiagnosisTerm t;
    t.effect = e;
    t.proxy = StateProxy::integral;
    const Eigen::MatrixXd g = term_features(t, s);
    ASSERT_EQ(g.cols(), feature_count(t)) << to_string(e);
    for (Eigen::Index j = 0; j < g.cols(); ++j) {
      EXPECT_GT(g.col(j).norm(), 1.0) << to_string(e);
      EXPECT_LT(std::abs(g.col(j).dot(s.integral)) / (g.col(j).norm() * s.integral.norm()), 1e-10) << to_string(e);
    }
  }
}

}  // namespace
}  // namespace panelbass::models

// Diagnosis of block structure and the newer physics terms: a static nonlinearity between two filters
// (Wiener–Hammerstein) and after the dynamics (Wiener) is named with where it sits and its shape, on systems
// built here from two known filters and a known static function (its shape: the slope beyond its knee); where a
// static function sits decides whether it is a saturation of the drive; the features of nonlinear damping and of
// an asymmetric force factor carry nothing a linear model of their state already explains.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <string>
#include <vector>

#include "models/diagnosis/diagnosis.h"
#include "models/diagnosis/diagnosis_static_nonlinearity.h"
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
  // The diode's slope beyond its knee is a tenth of the slope inside, on the side it bends (diode() above); the
  // other side stays straight.
  const nlohmann::json ratios = f.parameters.value("slope_beyond_knee_over_inside", nlohmann::json::array());
  ASSERT_EQ(ratios.size(), 2u) << f.parameters.dump();
  EXPECT_NEAR(ratios[0].get<double>(), 0.1, 0.1) << f.parameters.dump();
  EXPECT_NEAR(ratios[1].get<double>(), 1.0, 0.1) << f.parameters.dump();
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

// An all-pole filter at rate `fs` with the continuous poles given as (natural frequency Hz, damping ratio): a
// damping ratio of 1 is one real pole at that corner, below 1 a conjugate pair; z = exp(s/fs).
TransferFunction poles_at(const std::vector<std::pair<double, double>>& groups, double fs) {
  std::vector<std::complex<double>> z;
  for (const auto& [f, zeta] : groups) {
    const double w = 2.0 * std::numbers::pi * f;
    if (zeta >= 1.0) {
      z.emplace_back(std::exp(-w / fs), 0.0);
    } else {
      const std::complex<double> s(-zeta * w, w * std::sqrt(1.0 - zeta * zeta));
      z.push_back(std::exp(s / fs));
      z.push_back(std::conj(z.back()));
    }
  }
  const Eigen::VectorXd a = polynomial_from_roots(Eigen::Map<Eigen::VectorXcd>(z.data(), static_cast<Eigen::Index>(z.size())));
  TransferFunction tf;
  tf.a = a.tail(a.size() - 1);
  tf.b = Eigen::VectorXd::Ones(1);
  return tf;
}

// Where a static function sits decides its name: at the drive end — nothing before it, or only a filter of the
// drive (real poles and well-damped pairs above the lowest resonance) — it is the amplifier's saturation. The panel
// exciter's shape at 3000 Hz: the main resonance at 150 Hz, a panel mode at 1000 Hz, a converter's real pole at
// 740 Hz and Butterworth pair at 1200 Hz.
TEST(DiagnosisStructure, AStaticFunctionIsAtTheDriveEndOnlyBehindNothingButTheDrivesFilter) {
  constexpr double fs = 3000.0;
  const std::pair<double, double> resonance{150.0, 0.05}, mode{1000.0, 0.03}, corner{740.0, 1.0}, butterworth{1200.0, 0.38};
  const TransferFunction dynamics = poles_at({resonance, mode, corner, butterworth}, fs);
  TransferFunction nothing;
  nothing.b = Eigen::VectorXd::Ones(1);
  EXPECT_TRUE(diagnosis_detail::at_drive_end(nothing, dynamics, fs));                           // the drive as sampled
  EXPECT_TRUE(diagnosis_detail::at_drive_end(poles_at({corner}, fs), dynamics, fs));            // the converter's pole
  EXPECT_TRUE(diagnosis_detail::at_drive_end(poles_at({corner, butterworth}, fs), dynamics, fs));
  EXPECT_FALSE(diagnosis_detail::at_drive_end(poles_at({resonance}, fs), dynamics, fs));        // the mechanics before it
  EXPECT_FALSE(diagnosis_detail::at_drive_end(poles_at({corner, resonance}, fs), dynamics, fs));
  EXPECT_FALSE(diagnosis_detail::at_drive_end(poles_at({mode}, fs), dynamics, fs));             // a mode, not a filter
  EXPECT_FALSE(diagnosis_detail::at_drive_end(poles_at({{50.0, 1.0}}, fs), dynamics, fs));      // below the resonance
  // Without a resonance (two filters, as Wiener–Hammerstein 2009's) nothing tells the drive's filter from the rest.
  EXPECT_FALSE(diagnosis_detail::at_drive_end(poles_at({corner}, fs), poles_at({corner, butterworth}, fs), fs));
}

}  // namespace
}  // namespace panelbass::models

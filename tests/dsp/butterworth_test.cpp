// Butterworth design and the SOS filter, against the closed-form magnitude responses of the analog
// prototype and of its bilinear transform, and against the filter's own impulse response.
#include "dsp/butterworth.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unsupported/Eigen/FFT>
#include <vector>

#include "dsp/biquad.h"
#include "tests/support/expect_error.h"

namespace panelbass::dsp {
namespace {

using std::numbers::pi;

// Bilinear Butterworth magnitudes: with Ω = tan(πf/fs) the design is the analog prototype at Ω, so
// |H_lp| = 1/sqrt(1 + (Ω/Ωc)^(2n)) and |H_hp| = 1/sqrt(1 + (Ωc/Ω)^(2n)).
double lowpass_magnitude(int order, double f, double fc, double fs) {
  const double ratio = std::tan(pi * f / fs) / std::tan(pi * fc / fs);
  return 1.0 / std::sqrt(1.0 + std::pow(ratio, 2 * order));
}

double highpass_magnitude(int order, double f, double fc, double fs) {
  const double ratio = std::tan(pi * fc / fs) / std::tan(pi * f / fs);
  return 1.0 / std::sqrt(1.0 + std::pow(ratio, 2 * order));
}

std::complex<double> analog_response(const std::vector<AnalogSection>& sections, double omega) {
  const std::complex<double> s(0.0, omega);
  std::complex<double> h(1.0, 0.0);
  for (const AnalogSection& a : sections) {
    h *= a.first_order ? a.omega / (s + a.omega)
                       : a.omega * a.omega / (s * s + (a.omega / a.q) * s + a.omega * a.omega);
  }
  return h;
}

using testing_support::expect_invalid;

TEST(SosFilterTest, ABlockIsTheSamplesFilteredOneByOneToTheBit) {
  // 1 to 5 sections (the block loop specialises up to 4), uneven blocks, in place and not.
  for (int order : {1, 2, 4, 6, 8, 10}) {
    SosFilter by_sample(butterworth_lowpass(order, 700.0, 3000.0)), by_block = by_sample;
    std::vector<double> x(200), y(200);
    for (std::size_t k = 0; k < x.size(); ++k) x[k] = std::sin(0.37 * static_cast<double>(k)) + (k % 7 == 0 ? 1.0 : 0.0);
    std::size_t pos = 0;
    for (std::size_t block : {1, 63, 64, 72}) {
      by_block.process_block({x.data() + pos, block}, {y.data() + pos, block});
      pos += block;
    }
    std::vector<double> in_place = x;
    SosFilter third = by_sample;
    third.process_block(in_place, in_place);
    for (std::size_t k = 0; k < x.size(); ++k) {
      const double expected = by_sample.process(x[k]);
      ASSERT_EQ(y[k], expected) << "order " << order << ", sample " << k;
      ASSERT_EQ(in_place[k], expected) << "order " << order << ", sample " << k;
    }
  }
}

TEST(ButterworthTest, LowpassMinusThreeDecibelsAtCutoff) {
  const double fs = 3000.0;
  for (int order = 1; order <= 8; ++order) {
    for (const double fc : {30.0, 300.0, 1200.0}) {
      const SosFilter filter(butterworth_lowpass(order, fc, fs));
      EXPECT_NEAR(std::abs(filter.response(fc, fs)), 1.0 / std::sqrt(2.0), 1e-9)
          << "order " << order << " fc " << fc;
      EXPECT_NEAR(20.0 * std::log10(std::abs(filter.response(fc, fs))), -3.0103, 1e-4);
      EXPECT_NEAR(std::abs(filter.response(0.0, fs)), 1.0, 1e-12);
    }
  }
}

TEST(ButterworthTest, HighpassMinusThreeDecibelsAtCutoff) {
  const double fs = 3000.0;
  for (int order = 1; order <= 8; ++order) {
    for (const double fc : {30.0, 300.0, 1200.0}) {
      const SosFilter filter(butterworth_highpass(order, fc, fs));
      EXPECT_NEAR(std::abs(filter.response(fc, fs)), 1.0 / std::sqrt(2.0), 1e-9)
          << "order " << order << " fc " << fc;
      EXPECT_NEAR(std::abs(filter.response(fs / 2.0, fs)), 1.0, 1e-12);
    }
  }
}

TEST(ButterworthTest, MagnitudeMatchesBilinearClosedForm) {
  const double fs = 3000.0;
  const double fc = 250.0;
  for (int order = 1; order <= 16; ++order) {
    const SosFilter lp(butterworth_lowpass(order, fc, fs));
    const SosFilter hp(butterworth_highpass(order, fc, fs));
    for (double f = 5.0; f < fs / 2.0; f += 37.0) {
      EXPECT_NEAR(std::abs(lp.response(f, fs)), lowpass_magnitude(order, f, fc, fs), 1e-9)
          << "order " << order << " f " << f;
      EXPECT_NEAR(std::abs(hp.response(f, fs)), highpass_magnitude(order, f, fc, fs), 1e-9)
          << "order " << order << " f " << f;
    }
  }
}

TEST(ButterworthTest, SectionLayoutAndStability) {
  for (int order = 1; order <= 16; ++order) {
    for (const auto& sections :
         {butterworth_lowpass(order, 5.0, 48000.0), butterworth_highpass(order, 20000.0, 48000.0)}) {
      ASSERT_EQ(sections.size(), static_cast<std::size_t>((order + 1) / 2));
      if (order % 2 == 1) {
        EXPECT_EQ(sections.back().b2, 0.0);
        EXPECT_EQ(sections.back().a2, 0.0);
      }
      // Poles inside the unit circle (the stability triangle |a2| < 1, |a1| < 1 + a2).
      for (const Biquad& b : sections) {
        EXPECT_LT(std::abs(b.a2), 1.0);
        EXPECT_LT(std::abs(b.a1), 1.0 + b.a2);
      }
    }
  }
}

TEST(ButterworthTest, BandpassPassbandAndEdges) {
  const double fs = 3000.0;
  const int order = 4;
  const SosFilter bp(butterworth_bandpass(order, 100.0, 1000.0, fs));
  EXPECT_EQ(bp.sections().size(), 4u);
  const double center = std::sqrt(100.0 * 1000.0);
  EXPECT_NEAR(std::abs(bp.response(center, fs)), 1.0, 1e-3);
  for (double f = 10.0; f < fs / 2.0; f += 41.0) {
    const double expected =
        highpass_magnitude(order, f, 100.0, fs) * lowpass_magnitude(order, f, 1000.0, fs);
    EXPECT_NEAR(std::abs(bp.response(f, fs)), expected, 1e-9) << "f " << f;
  }
}

TEST(ButterworthTest, AnalogPrototypeMagnitude) {
  const double fc = 440.0;
  const double wc = 2.0 * pi * fc;
  for (int order = 1; order <= 16; ++order) {
    const auto sections = analog_butterworth_lowpass(order, fc);
    ASSERT_EQ(sections.size(), static_cast<std::size_t>((order + 1) / 2));
    EXPECT_EQ(sections.back().first_order, order % 2 == 1);
    for (const double ratio : {0.01, 0.3, 0.9, 1.0, 1.1, 2.0, 10.0}) {
      const double expected = 1.0 / std::sqrt(1.0 + std::pow(ratio, 2 * order));
      EXPECT_NEAR(std::abs(analog_response(sections, ratio * wc)) / expected, 1.0, 1e-9)
          << "order " << order << " ω/ωc " << ratio;
    }
  }
  // Order 2: the single section has q = 1/√2.
  EXPECT_NEAR(analog_butterworth_lowpass(2, fc)[0].q, 1.0 / std::sqrt(2.0), 1e-15);
}

TEST(ButterworthTest, InvalidDesignsNameTheParameter) {
  expect_invalid([] { butterworth_lowpass(0, 100.0, 1000.0); }, "order");
  expect_invalid([] { butterworth_highpass(17, 100.0, 1000.0); }, "order");
  expect_invalid([] { analog_butterworth_lowpass(0, 100.0); }, "order");
  expect_invalid([] { analog_butterworth_lowpass(2, -1.0); }, "cutoff_hz");
  expect_invalid([] { butterworth_lowpass(2, 0.0, 1000.0); }, "cutoff_hz");
  expect_invalid([] { butterworth_lowpass(2, 500.0, 1000.0); }, "cutoff_hz");
  expect_invalid([] { butterworth_highpass(2, std::nan(""), 1000.0); }, "cutoff_hz");
  expect_invalid([] { butterworth_lowpass(2, 100.0, 0.0); }, "fs");
  expect_invalid([] { butterworth_bandpass(2, 300.0, 200.0, 1000.0); }, "low_hz");
  expect_invalid([] { butterworth_bandpass(2, 100.0, 600.0, 1000.0); }, "high_hz");
}

// ---- SosFilter ------------------------------------------------------------------------------

TEST(SosFilterTest, BiquadResponseMatchesClosedForm) {
  // b0 = b1 = 1: H = 1 + e^{−jω} = 2 cos(ω/2) e^{−jω/2}.
  Biquad fir;
  fir.b0 = 1.0;
  fir.b1 = 1.0;
  // One pole at p: H = 1 / (1 − p e^{−jω}).
  Biquad pole;
  pole.a1 = -0.8;
  for (double f = 0.0; f < 500.0; f += 23.0) {
    const double w = 2.0 * pi * f / 1000.0;
    const std::complex<double> expected_fir = 2.0 * std::cos(w / 2.0) * std::polar(1.0, -w / 2.0);
    EXPECT_LT(std::abs(fir.response(f, 1000.0) - expected_fir), 1e-12);
    const std::complex<double> expected_pole = 1.0 / (1.0 - 0.8 * std::polar(1.0, -w));
    EXPECT_LT(std::abs(pole.response(f, 1000.0) - expected_pole), 1e-12);
  }
}

TEST(SosFilterTest, ImpulseResponseSpectrumMatchesResponse) {
  const double fs = 3000.0;
  SosFilter filter(butterworth_bandpass(3, 60.0, 900.0, fs));
  const int n = 4096;  // long enough for the impulse response to decay below rounding
  std::vector<double> impulse(n);
  for (int i = 0; i < n; ++i) {
    impulse[i] = filter.process(i == 0 ? 1.0 : 0.0);
  }
  std::vector<std::complex<double>> spectrum;
  Eigen::FFT<double> fft;
  fft.fwd(spectrum, impulse);
  for (int k = 0; k <= n / 2; k += 7) {
    const double f = k * fs / n;
    EXPECT_LT(std::abs(spectrum[k] - filter.response(f, fs)), 1e-9) << "bin " << k;
  }
}

TEST(SosFilterTest, DifferenceEquationOfOneSection) {
  // y[n] = b0 x[n] + b1 x[n−1] + b2 x[n−2] − a1 y[n−1] − a2 y[n−2], written out directly.
  Biquad b{0.2, -0.3, 0.15, -0.5, 0.25};
  SosFilter filter({b});
  Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(50, -1.0, 2.0).array().sin();
  std::vector<double> y(50, 0.0);
  for (int n = 0; n < 50; ++n) {
    y[n] = b.b0 * x[n] + (n >= 1 ? b.b1 * x[n - 1] - b.a1 * y[n - 1] : 0.0) +
           (n >= 2 ? b.b2 * x[n - 2] - b.a2 * y[n - 2] : 0.0);
    EXPECT_NEAR(filter.process(x[n]), y[n], 1e-14) << "sample " << n;
  }
}

TEST(SosFilterTest, VectorProcessEqualsSampleBySample) {
  const auto sections = butterworth_lowpass(5, 200.0, 3000.0);
  SosFilter whole(sections);
  SosFilter by_sample(sections);
  SosFilter in_halves(sections);
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(1000, 0.0, 99.0).array().sin();
  const Eigen::VectorXd y = whole.process(x);
  const Eigen::VectorXd first = in_halves.process(x.head(400));
  const Eigen::VectorXd second = in_halves.process(x.tail(600));
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    ASSERT_EQ(y[i], by_sample.process(x[i]));
    ASSERT_EQ(y[i], i < 400 ? first[i] : second[i - 400]);
  }
}

TEST(SosFilterTest, ResetClearsState) {
  SosFilter filter(butterworth_highpass(4, 100.0, 3000.0));
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(300, -3.0, 7.0).array().cos();
  const Eigen::VectorXd fresh = filter.process(x);
  filter.process(x);  // leaves a non-zero state
  filter.reset();
  const Eigen::VectorXd again = filter.process(x);
  EXPECT_TRUE(std::equal(fresh.data(), fresh.data() + fresh.size(), again.data()));
}

TEST(SosFilterTest, EmptyCascadeIsIdentityAndProcessIsNoexcept) {
  SosFilter identity;
  EXPECT_EQ(identity.process(0.375), 0.375);
  EXPECT_EQ(identity.response(123.0, 1000.0), std::complex<double>(1.0, 0.0));
  static_assert(noexcept(identity.process(1.0)));
  static_assert(noexcept(identity.reset()));
}

}  // namespace
}  // namespace panelbass::dsp

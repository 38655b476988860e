#pragma once
// Excitation signals for identification and analysis. Every random one takes a seed; periodic ones
// are exactly periodic (one period computed, then repeated bit for bit).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace panelbass::dsp {

/// Uniformly distributed white noise in [-amplitude, amplitude] (the thesis's excitation).
Eigen::VectorXd uniform_noise(std::size_t samples, double amplitude, std::uint64_t seed);

/// White Gaussian noise with standard deviation amplitude/3, truncated to [-amplitude, amplitude]
/// by redrawing (so a drive never leaves its range and no value is clipped).
Eigen::VectorXd gaussian_noise(std::size_t samples, double amplitude, std::uint64_t seed);

/// Which DFT lines of a multisine carry energy.
enum class MultisineLines {
  all,         ///< every line in the band
  odd,         ///< odd lines only (even-order distortion lands on the empty even lines)
  random_odd,  ///< odd lines, one in each group of `group` consecutive odd lines left out at random
};

/// What a random-phase multisine is made of.
struct MultisineSpec {
  std::size_t period = 4096;   ///< samples per period (the DFT length)
  std::size_t periods = 1;     ///< number of periods in the signal
  double fs = 3000.0;          ///< sample rate, Hz
  double f_min = 0.0;          ///< lowest excited frequency, Hz (line 0, DC, is never excited)
  double f_max = 1200.0;       ///< highest excited frequency, Hz (at most fs/2, Nyquist excluded)
  MultisineLines lines = MultisineLines::all;
  std::size_t group = 4;       ///< group size for random_odd
  double amplitude = 1.0;      ///< the peak of the signal: max |x| equals this
  std::uint64_t seed = 1;      ///< seeds the random phases (and the detection lines)
};

/// A multisine and the lines it excites.
struct Multisine {
  Eigen::VectorXd signal;             ///< periods * period samples
  std::vector<std::size_t> lines;     ///< excited DFT bins k (frequency k * fs / period), ascending
  std::vector<std::size_t> detection_lines;  ///< odd lines in the band left out (random_odd only)
};

/// Random-phase multisine with equal amplitudes on the chosen lines, scaled to the given peak.
/// Throws std::invalid_argument for an empty band, period < 4, or a band beyond Nyquist.
Multisine multisine(const MultisineSpec& spec);

/// Exponential (logarithmic) sweep from f_start to f_stop Hz over `samples` samples.
Eigen::VectorXd log_sweep(std::size_t samples, double fs, double f_start, double f_stop,
                          double amplitude);

/// A sine of `frequency` Hz starting at phase 0.
Eigen::VectorXd sine(std::size_t samples, double fs, double frequency, double amplitude);

/// One step of a stepped sine: its frequency and where its steady-state part lies.
struct SineStep {
  double frequency = 0.0;        ///< Hz (snapped so the measured part holds whole periods)
  std::size_t measure_start = 0; ///< first sample of the part to analyse
  std::size_t measure_length = 0;///< its length
};

/// What a stepped sine is made of.
struct SteppedSineSpec {
  std::vector<double> frequencies;   ///< requested frequencies, Hz
  double fs = 3000.0;
  double amplitude = 1.0;
  std::size_t settle = 600;          ///< samples at each step before the measured part
  std::size_t measure = 3000;        ///< samples measured at each step
};

/// A stepped sine and where each step's measured part is.
struct SteppedSine {
  Eigen::VectorXd signal;
  std::vector<SineStep> steps;
};

/// Consecutive sines, each frequency snapped to the nearest DFT bin of the measured window so that
/// harmonics fall exactly on bins; the phase is continuous from one step to the next.
SteppedSine stepped_sine(const SteppedSineSpec& spec);

}  // namespace panelbass::dsp

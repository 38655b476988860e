#include "evaluation/window_distortion.h"

#include <cmath>
#include <stdexcept>

#include "dsp/harmonics.h"
#include "dsp/sine_fit.h"

namespace panelbass::evaluation {

WindowDistortion window_distortion(const Eigen::VectorXd& drive, const Eigen::VectorXd& sensor,
                                   const Eigen::VectorXd& clean, double fs) {
  if (sensor.size() != drive.size() || clean.size() != drive.size()) {
    throw std::invalid_argument("window distortion: the drive, sensor and clean columns differ in length");
  }
  WindowDistortion w;
  if (drive.size() == 0) return w;
  w.drive_rms = std::sqrt(drive.squaredNorm() / static_cast<double>(drive.size()));
  w.drive_peak = drive.cwiseAbs().maxCoeff();
  if (!(w.drive_rms > 1e-9)) return w;
  w.frequency_hz = dsp::dominant_frequency(drive, fs);
  if (!w.frequency_hz || !(*w.frequency_hz > 0.0 && *w.frequency_hz < fs / 2.0)) {
    w.frequency_hz.reset();
    return w;
  }
  const double f = *w.frequency_hz;
  const std::optional<dsp::SteadyThd> d = dsp::steady_thd(drive, fs, f);
  const std::optional<dsp::SteadyThd> c = dsp::steady_thd(clean, fs, f);
  const std::optional<dsp::SteadyThd> s = dsp::steady_thd(sensor, fs, f);
  if (d) {
    w.drive_fundamental = d->fundamental;
    w.drive_thd_pct = d->measured_thd_pct;
  }
  if (c) {
    w.clean_fundamental = c->fundamental;
    w.clean_thd_pct = c->measured_thd_pct;  // noise-free: the harmonics as they are
  }
  if (s) {
    w.sensor_fundamental = s->fundamental;
    w.sensor_thd_pct = s->thd_pct;
    w.sensor_measured_thd_pct = s->measured_thd_pct;
    w.sensor_floor_pct = s->floor_pct;
    w.sensor_at_floor = s->at_floor;
  }
  return w;
}

}  // namespace panelbass::evaluation

#include "usecases/card_measurement.h"

#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "dsp/excitation.h"
#include "engine/measurement.h"
#include "models/io/number_text.h"

namespace panelbass::usecases {
namespace {

// How long a measurement waits for a device lost under it to be reopened (the backend's back-off starts at 50 ms and
// doubles up to 2 s) before it fails.
constexpr std::chrono::seconds kDeviceBack{5};

}  // namespace

std::optional<std::string> card_cannot_measure(const engine::AlsaOptions& card) {
  if (card.sensor_channel != engine::kNoChannel || card.loopback_channel != engine::kNoChannel) return std::nullopt;
  return "the card captures neither a sensor nor the drive's loopback, so a measurement's round trip cannot be found "
         "(--sensor-channel or --loopback-channel)";
}

Playback measure_through_card(engine::AlsaBackend& alsa, const engine::AlsaOptions& card,
                              const CardMeasurementSettings& settings, const Eigen::VectorXd& drive) {
  const double fs = settings.fs, safe = settings.safe_level;
  const double peak = drive.size() > 0 ? drive.cwiseAbs().maxCoeff() : 0.0;
  if (!drive.allFinite() || peak > safe) {
    throw std::invalid_argument("excite: the drive's peak " + models::number_text(peak) + " exceeds the card's safe level " +
                                models::number_text(safe) + " (--safe-level)");
  }
  if (const std::optional<std::string> why = card_cannot_measure(card)) throw std::invalid_argument("excite: " + *why);
  const bool sensed = card.sensor_channel != engine::kNoChannel;
  // The played sequence: a calibration sweep (faded in and out), a gap, the drive, and a tail of silence
  // long enough for the longest round trip looked for.
  const auto samples = [&](double seconds) { return static_cast<Eigen::Index>(std::llround(seconds * fs)); };
  const Eigen::Index sweep_n = samples(0.25), gap = samples(0.05), tail = samples(0.25), fade = samples(0.005);
  Eigen::VectorXd sweep = dsp::log_sweep(static_cast<std::size_t>(sweep_n), fs, 20.0, 0.4 * fs, 0.5 * safe);
  for (Eigen::Index k = 0; k < fade; ++k) {
    const double g = 0.5 - 0.5 * std::cos(M_PI * static_cast<double>(k) / static_cast<double>(fade));
    sweep[k] *= g;
    sweep[sweep_n - 1 - k] *= g;
  }
  const Eigen::Index offset = sweep_n + gap;
  // The sweep again after the drive: the round trip found on each must agree.
  const Eigen::Index second = offset + drive.size() + gap;
  std::vector<double> played(static_cast<std::size_t>(second + sweep_n + tail), 0.0);
  for (Eigen::Index k = 0; k < sweep_n; ++k) {
    played[static_cast<std::size_t>(k)] = sweep[k];
    played[static_cast<std::size_t>(second + k)] = sweep[k];
  }
  for (Eigen::Index k = 0; k < drive.size(); ++k) played[static_cast<std::size_t>(offset + k)] = drive[k];
  const auto duration = std::chrono::milliseconds(static_cast<long long>(1e3 * static_cast<double>(played.size()) / fs));
  const auto as_vector = [](const std::vector<double>& x) {
    return Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size())).eval();
  };
  const bool loopback = card.loopback_channel != engine::kNoChannel;
  const auto began = std::chrono::steady_clock::now();
  // The round trip is found on the sweep before the drive (unambiguous, whatever the drive). A loop that
  // slips inside the device's server (JACK on a loaded machine: a period dropped or repeated, no xrun
  // counted) shifts part of a measurement: the loopback, when captured, must be explained by the drive
  // sample by sample (engine::check_loop), and the round trips found on the sweep after the drive (on the
  // loopback and on the sensor) must agree with the one before; else the measurement is played again (at
  // most three times in all), as it is when an xrun interrupted it.
  std::unique_ptr<engine::Measurement> m;
  engine::RoundTrip trip;
  engine::LoopConsistency loop;
  std::string slip;
  int attempts = 0;
  for (bool consistent = false; !consistent;) {
    if (++attempts > 3) {
      throw std::runtime_error("excite: the capture slipped against the playback, or an xrun interrupted it, in each of 3 "
                               "measurements (the last: " + slip + "): is the machine overloaded?");
    }
    m = std::make_unique<engine::Measurement>(played, static_cast<std::size_t>(std::max<Eigen::Index>(1, samples(settings.fade_seconds))));
    if (alsa.measure(*m, duration + std::chrono::seconds(10)) != engine::Measurement::State::finished) {
      // An xrun (a loaded machine: the device thread late once) is played again, as a slip is, and so is a device
      // lost and reopened by the backend within kDeviceBack; a device that does not stream again is not.
      const engine::AlsaStatus was = alsa.status();
      const auto give_up = std::chrono::steady_clock::now() + kDeviceBack;
      while (alsa.status().state != engine::AlsaState::running && std::chrono::steady_clock::now() < give_up) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
      if (alsa.status().state != engine::AlsaState::running) {
        throw std::runtime_error(std::string("excite: the measurement through the card was interrupted and the device "
                                             "did not stream again (last error: ") + was.last_error.data() +
                                 "; see the device's status)");
      }
      slip = std::string(was.state == engine::AlsaState::running ? "an xrun interrupted it" : "the device was lost") +
             " (" + was.last_error.data() + ")";
      continue;
    }
    const Eigen::VectorXd sent = as_vector(m->drive());
    const Eigen::VectorXd sensor = as_vector(m->captured(engine::MeasuredChannel::sensor));
    const Eigen::VectorXd reference = loopback ? as_vector(m->captured(engine::MeasuredChannel::loopback)) : sensor;
    if (reference.cwiseAbs().maxCoeff() == 0.0) {
      throw std::runtime_error(std::string("excite: the card's ") + (loopback ? "loopback" : "sensor") +
                               " channel stayed silent: nothing of the drive came back (is the transducer connected?)");
    }
    const auto over = [&](const Eigen::VectorXd& heard, Eigen::Index start) {
      // The sweep alone against what came back while it and the round trip after it lasted.
      Eigen::VectorXd alone = Eigen::VectorXd::Zero(sweep_n + tail);
      alone.head(sweep_n) = sent.segment(start, sweep_n);
      return engine::find_round_trip(alone, heard.segment(start, sweep_n + tail), tail);
    };
    trip = over(reference, 0);
    // Moved by more than `tolerance` samples between the sweeps. The sensor (a resonant transducer, noise) gets
    // two: a slip is a whole device period (4 samples of a 64-frame period at 48 kHz, for a 3000 Hz chain).
    const auto moved = [&](const Eigen::VectorXd& heard, int tolerance) {
      return std::abs(over(heard, second).samples - over(heard, 0).samples) > tolerance;
    };
    if (moved(reference, loopback ? 1 : 2) || (loopback && sensed && moved(sensor, 2))) {
      slip = "the round trip differed between the sweeps before and after the drive";
      continue;
    }
    if (loopback) {
      loop = engine::check_loop(sent, reference, trip.samples, engine::kLoopTolerance);
      if (loop.slipped) {
        slip = "the loopback departed from the drive at " + models::number_text(static_cast<double>(loop.worst_at) / fs) +
               " s (residual " + models::number_text(loop.worst_residual) + ")";
        continue;
      }
    }
    consistent = true;
  }
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
  const Eigen::VectorXd heard_sensor = as_vector(m->captured(engine::MeasuredChannel::sensor));
  Playback out;
  if (sensed) out.sensor = heard_sensor.segment(offset + trip.samples, drive.size());
  if (card.current_channel != engine::kNoChannel) {
    out.current = as_vector(m->captured(engine::MeasuredChannel::current)).segment(offset + trip.samples, drive.size());
  }
  if (loopback) {
    out.loopback = as_vector(m->captured(engine::MeasuredChannel::loopback)).segment(offset + trip.samples, drive.size());
  }
  out.report = {{"calibrated_on", loopback ? "loopback" : "sensor"},
                {"round_trip_samples", trip.samples},
                {"round_trip_fractional", trip.fractional},
                {"round_trip_ms", 1e3 * trip.fractional / fs},
                {"peak_correlation", trip.peak},
                {"safe_level", safe},
                {"attempts", attempts},
                {"loop_residual", loopback ? nlohmann::json(loop.worst_residual) : nlohmann::json(nullptr)},
                {"played_s", static_cast<double>(played.size()) / fs},
                {"took_s", took}};
  return out;
}

}  // namespace panelbass::usecases

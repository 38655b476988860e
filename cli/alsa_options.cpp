#include "cli/alsa_options.h"

#include <fstream>
#include <iterator>
#include <stdexcept>

namespace panelbass::cli {
namespace {

engine::ResampleQuality quality_of(const std::string& name) {
  if (name == "best") return engine::ResampleQuality::best;
  if (name == "medium") return engine::ResampleQuality::medium;
  if (name == "fastest") return engine::ResampleQuality::fastest;
  return engine::ResampleQuality::low_latency;
}

}  // namespace

void add_alsa_options(CLI::App* cmd, AlsaCliOptions& o) {
  cmd->add_option("--playback", o.playback, "ALSA: playback PCM, feeding the amplifier (\"\" = none)")
      ->capture_default_str();
  cmd->add_option("--capture", o.capture, "ALSA: capture PCM with program input and/or sensor (default: none)");
  cmd->add_option("--rate", o.rate, "ALSA: device rate, Hz (another than the chain's puts a resampler between)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--period", o.period, "ALSA: period size, frames")->check(CLI::PositiveNumber)->capture_default_str();
  cmd->add_option("--periods", o.periods, "ALSA: periods in the device buffer")->capture_default_str();
  cmd->add_option("--playback-channels", o.playback_channels, "ALSA: channels of the playback PCM")
      ->capture_default_str();
  cmd->add_option("--drive-channel", o.drive_channel, "ALSA: playback channel carrying the drive (others silent)")
      ->capture_default_str();
  cmd->add_option("--capture-channels", o.capture_channels, "ALSA: channels of the capture PCM")->capture_default_str();
  cmd->add_option("--program-channel", o.program_channel,
                  "ALSA: capture channel with the program input (default: the program played from memory)");
  cmd->add_option("--sensor-channel", o.sensor_channel,
                  "ALSA: capture channel with the sensor (needed for a feedback stage in sensor mode)");
  cmd->add_option("--current-channel", o.current_channel,
                  "ALSA: capture channel with the coil current (recorded by measurements; default: none)");
  cmd->add_option("--loopback-channel", o.loopback_channel,
                  "ALSA: capture channel hearing the drive looped back, which calibrates a measurement's round trip "
                  "(default: none; the sensor then calibrates it, the transducer's own delay included)");
  cmd->add_option("--quality", o.quality, "ALSA: resampler when the device runs at another rate: low-latency (minimum-phase, ~1.5 ms) or "
                  "libsamplerate's fastest|medium|best (linear-phase, 13 ms and more)")
      ->check(CLI::IsMember({"low-latency", "fastest", "medium", "best"}))
      ->capture_default_str();
  cmd->add_option("--alsa-config", o.config_file,
                  "ALSA: configuration file defining the PCMs named above (default: the system's configuration)")
      ->check(CLI::ExistingFile);
}

engine::AlsaOptions alsa_options_of(const AlsaCliOptions& o) {
  engine::AlsaOptions options;
  options.playback_device = o.playback;
  options.capture_device = o.capture;
  options.rate = engine::Hertz{o.rate};
  options.period = engine::Samples{o.period};
  options.periods = o.periods;
  options.playback_channels = o.playback_channels;
  options.drive_channel = o.drive_channel;
  options.capture_channels = o.capture_channels;
  options.program_channel = o.program_channel;
  options.sensor_channel = o.sensor_channel;
  options.current_channel = o.current_channel;
  options.loopback_channel = o.loopback_channel;
  options.quality = quality_of(o.quality);
  if (!o.config_file.empty()) {
    std::ifstream in(o.config_file);
    if (!in) throw std::invalid_argument("--alsa-config " + o.config_file + ": cannot be read");
    options.config_text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return options;
}

}  // namespace panelbass::cli

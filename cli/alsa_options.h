#pragma once
// The sound-card options `run` and `serve` share (--playback, --capture, --rate, --period, …): read from
// the command line and turned into the ALSA backend's options.

#include <CLI/CLI.hpp>
#include <string>

#include "engine/alsa_backend.h"

namespace panelbass::cli {

/// The ALSA options as given on the command line.
struct AlsaCliOptions {
  std::string playback = "default";           ///< playback PCM feeding the amplifier ("" = none)
  std::string capture;                        ///< capture PCM with program input and/or sensor ("" = none)
  double rate = 48000.0;                      ///< device rate, Hz
  int period = 64;                            ///< period, frames
  int periods = 4;                            ///< periods in the device buffer
  int playback_channels = 2;                  ///< channels of the playback PCM
  int drive_channel = 0;                      ///< playback channel carrying the drive
  int capture_channels = 2;                   ///< channels of the capture PCM
  int program_channel = engine::kNoChannel;   ///< capture channel with the program input
  int sensor_channel = engine::kNoChannel;    ///< capture channel with the sensor
  int current_channel = engine::kNoChannel;   ///< capture channel with the coil current (measurements)
  int loopback_channel = engine::kNoChannel;  ///< capture channel hearing the drive itself (calibration)
  std::string quality = "low-latency";          ///< the rate bridge's resampler quality
  std::string config_file;                    ///< ALSA configuration file to open the PCMs from ("" = system's)
};

/// Adds the --playback … --alsa-config options to `cmd`, stored in `o`.
void add_alsa_options(CLI::App* cmd, AlsaCliOptions& o);

/// The backend's options (program and on_block left empty); throws std::invalid_argument naming
/// --alsa-config when its file cannot be read.
engine::AlsaOptions alsa_options_of(const AlsaCliOptions& o);

}  // namespace panelbass::cli

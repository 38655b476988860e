// `panelbass transducer --jack`: the virtual transducer (any plant) as a JACK client — drive in, sensor and
// coil current out at the server's rate — until interrupted or for a set time; then what it simulated. With
// --thd-log it appends a JSON line per window: the distortion judged from the transducer's own side.
#include <chrono>
#include <cstdint>
#include <fstream>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "cli/commands.h"
#include "cli/json_output.h"
#include "cli/stop_signals.h"
#include "engine/jack_transducer.h"
#include "evaluation/window_distortion.h"
#include "models/plant/plant_presets.h"

namespace panelbass::cli {
namespace {

struct TransducerOptions {
  bool jack = false;
  std::string plant = "panel-exciter";
  std::string name = "panelbass-transducer";
  std::string server;
  std::uint64_t seed = 1;
  double seconds = 0.0;
  std::vector<std::string> drive_from, sensor_to, current_to;
  std::string thd_log;
  double thd_window = 1.0;
};

nlohmann::json number_or_null(const std::optional<double>& x) { return x ? nlohmann::json(*x) : nlohmann::json(nullptr); }

// One line of the THD log: window `w` of `transducer`, judged (on this thread, not the process callback's).
nlohmann::json thd_line(const engine::RecordedWindow& w, double rate) {
  const auto column = [](const std::vector<double>& v) {
    return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
  };
  const evaluation::WindowDistortion d = evaluation::window_distortion(column(w.drive), column(w.sensor), column(w.clean), rate);
  const auto frames = w.first_frame + w.drive.size();
  const double unix_s =
      std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  return {{"time_s", static_cast<double>(frames) / rate},
          {"unix_time_s", unix_s},
          {"frames", frames},
          {"window_frames", w.drive.size()},
          {"drive_rms", d.drive_rms},
          {"drive_peak", d.drive_peak},
          {"frequency_hz", number_or_null(d.frequency_hz)},
          {"drive_fundamental", d.drive_fundamental},
          {"drive_thd_pct", number_or_null(d.drive_thd_pct)},
          {"sensor_fundamental", d.sensor_fundamental},
          {"clean_fundamental", d.clean_fundamental},
          {"thd_clean_pct", number_or_null(d.clean_thd_pct)},
          {"thd_sensor_pct", number_or_null(d.sensor_thd_pct)},
          {"thd_sensor_measured_pct", number_or_null(d.sensor_measured_thd_pct)},
          {"thd_sensor_floor_pct", number_or_null(d.sensor_floor_pct)},
          {"sensor_at_floor", d.sensor_at_floor}};
}

void run_transducer(const TransducerOptions& o) {
  if (!o.jack) throw CLI::ValidationError("--jack", "the only way to run the transducer is as a JACK client: pass --jack");
  engine::JackTransducerOptions options;
  options.plant = models::plant_from_name_or_file(o.plant);
  options.client_name = o.name;
  options.server_name = o.server;
  options.noise_seed = o.seed;
  options.drive_from = o.drive_from;
  options.sensor_to = o.sensor_to;
  options.current_to = o.current_to;
  options.record_window_s = o.thd_log.empty() ? 0.0 : o.thd_window;
  std::ofstream log;
  if (!o.thd_log.empty()) {
    log.open(o.thd_log, std::ios::app);
    if (!log) throw std::invalid_argument("--thd-log " + o.thd_log + ": cannot open for appending");
  }
  const StopSignals signals;
  engine::JackTransducer transducer(options);
  std::cerr << "transducer: " << options.plant.name << " at " << transducer.rate() << " Hz as JACK client "
            << transducer.name() << " (" << transducer.drive_port() << " in; " << transducer.sensor_port() << ", "
            << transducer.current_port() << " out)" << std::endl;
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(o.seconds);
  std::uint64_t lines = 0;
  const auto write_windows = [&] {
    while (const engine::RecordedWindow* w = transducer.next_window()) {
      log << thd_line(*w, transducer.rate()).dump() << std::endl;
      transducer.release_window();
      ++lines;
    }
  };
  while (!stop_requested() && !transducer.shut_down() && (o.seconds <= 0.0 || std::chrono::steady_clock::now() < until)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (log.is_open()) write_windows();
  }
  if (log.is_open()) write_windows();
  print_result({{"client", transducer.name()},
                {"plant", options.plant.name},
                {"rate", transducer.rate()},
                {"frames", transducer.frames()},
                {"peak_drive", transducer.peak_drive()},
                {"server_shut_down", transducer.shut_down()},
                {"thd_log", o.thd_log.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.thd_log)},
                {"thd_lines", lines},
                {"thd_dropped_frames", transducer.dropped_frames()}});
}

}  // namespace

void register_transducer(CLI::App& app) {
  auto o = std::make_shared<TransducerOptions>();
  CLI::App* cmd = app.add_subcommand(
      "transducer", "Run the virtual transducer as a JACK client: drive in, sensor and current out (no hardware needed)");
  cmd->add_flag("--jack", o->jack, "Run as a JACK client (required; the server must be running)");
  cmd->add_option("--plant", o->plant, "Preset (panel-exciter, linear) or plant JSON file; simulated at the server's rate")
      ->capture_default_str();
  cmd->add_option("--name", o->name, "JACK client name (ports <name>:drive, <name>:sensor, <name>:current)")
      ->capture_default_str();
  cmd->add_option("--server", o->server, "JACK server name (default: $JACK_DEFAULT_SERVER, else the default server)");
  cmd->add_option("--seed", o->seed, "Seed of the sensor noise")->capture_default_str();
  cmd->add_option("--seconds", o->seconds, "Stop after this long (default: run until Ctrl-C)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--drive-from", o->drive_from, "JACK port(s) to connect to the drive input (e.g. system:capture_1)");
  cmd->add_option("--sensor-to", o->sensor_to, "JACK port(s) to connect the sensor output to");
  cmd->add_option("--current-to", o->current_to, "JACK port(s) to connect the current output to");
  cmd->add_option("--thd-log", o->thd_log,
                  "Append a JSON line per window to FILE: time, frames, the drive's RMS, peak and dominant frequency, "
                  "the sensor's fundamental there, and the THD (harmonics 2..5, %) of the plant's noise-free "
                  "acceleration and of the sensor");
  cmd->add_option("--thd-window", o->thd_window, "Seconds per --thd-log line")
      ->check(CLI::Range(0.05, 60.0))
      ->capture_default_str();
  cmd->footer(
      "Example (a JACK server with the dummy driver stands in for the sound card; docs/engine.md shows the ALSA side):\n"
      "  jackd --no-realtime -S -n pb -d dummy -r 48000 -p 64 &\n"
      "  panelbass transducer --jack --server pb --plant panel-exciter --seconds 10 --thd-log thd.jsonl");
  cmd->callback([o] { run_transducer(*o); });
}

}  // namespace panelbass::cli

// `panelbass transducer --jack`: the virtual transducer (any plant) as a JACK client — drive in, sensor and
// coil current out at the server's rate — until interrupted or for a set time; then what it simulated.
#include <chrono>
#include <cstdint>
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
};

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
  const StopSignals signals;
  engine::JackTransducer transducer(options);
  std::cerr << "transducer: " << options.plant.name << " at " << transducer.rate() << " Hz as JACK client "
            << transducer.name() << " (" << transducer.drive_port() << " in; " << transducer.sensor_port() << ", "
            << transducer.current_port() << " out)" << std::endl;
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(o.seconds);
  while (!stop_requested() && !transducer.shut_down() && (o.seconds <= 0.0 || std::chrono::steady_clock::now() < until)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  print_result({{"client", transducer.name()},
                {"plant", options.plant.name},
                {"rate", transducer.rate()},
                {"frames", transducer.frames()},
                {"peak_drive", transducer.peak_drive()},
                {"server_shut_down", transducer.shut_down()}});
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
  cmd->footer(
      "Example (a JACK server with the dummy driver stands in for the sound card; docs/engine.md shows the ALSA side):\n"
      "  jackd --no-realtime -S -n pb -d dummy -r 48000 -p 64 &\n"
      "  panelbass transducer --jack --server pb --plant panel-exciter --seconds 10");
  cmd->callback([o] { run_transducer(*o); });
}

}  // namespace panelbass::cli

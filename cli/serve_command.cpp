// `panelbass serve`: the engine on the virtual transducer (or a sound card), the HTTP API and the web UI in
// one process. With --demo (the default, virtual transducer only) it excites the transducer, identifies a
// linear model, designs the LQ feedforward on it and activates it, so that a new user opens the address
// and sees everything working.
#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "api/server.h"
#include "cli/alsa_options.h"
#include "cli/commands.h"
#include "cli/looped_program.h"
#include "cli/stop_signals.h"
#include "models/io/number_text.h"
#include "models/plant/plant_presets.h"

namespace panelbass::cli {
namespace {

/// The web UI next to the running binary: <bin>/PANELBASS_WEB_FROM_BIN, i.e. /usr/share/panelbass/web for
/// /usr/bin/panelbass, and in a build tree the link CMake makes there to the source tree's web/. Empty if
/// the running binary cannot be found.
std::string default_web_dir() {
  std::error_code error;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) return {};
  return (exe.parent_path() / PANELBASS_WEB_FROM_BIN).lexically_normal().string();
}

struct ServeOptions {
  std::string bind = "127.0.0.1";
  int port = 8080;
  std::string token;
  std::vector<std::string> allow_origins;
  std::vector<std::string> allow_hosts;
  std::string store = "panelbass-store";
  std::string web = default_web_dir();
  std::string plant = "panel-exciter";
  std::string signal = "noise";
  double amplitude = 0.2;
  std::uint64_t seed = 1;
  int workers = 1;
  bool demo = true;
  double seconds = 0.0;
  std::size_t body_limit_mib = 16;
  std::string backend = "virtual";
  int realtime_priority = 0;
  double safe_level = 0.5;
  AlsaCliOptions alsa;
};

// Waits for `id` to end, printing its progress now and then; true if it succeeded.
bool follow_job(api::Server& server, const std::string& id, const std::string& what) {
  using namespace std::chrono_literals;
  while (!server.jobs().wait(id, 2000ms)) {
    const std::optional<api::JobRecord> job = server.jobs().get(id);
    if (!job) return false;
    std::cerr << "serve: " << what << " " << static_cast<int>(100.0 * job->progress) << " % " << job->message << "\n";
  }
  const std::optional<api::JobRecord> job = server.jobs().get(id);
  if (!job || job->state != api::JobState::succeeded) {
    std::cerr << "serve: " << what << " did not succeed: " << (job ? job->error : "unknown job") << "\n";
    return false;
  }
  return true;
}

// The start-up demo: excitation + linear identification, then the LQ feedforward on that model, designed so
// that the program's peak `program_peak` is within its safe amplitude (the drive it asks for stays within
// full scale, rather than sitting at the limiter), activated.
void run_demo(api::Server& server, double program_peak) {
  const std::string identify = server.submit_job(
      "identify-linear", {{"excite", {{"samples", 10000}, {"seed", 1}}}, {"method", "oe"}, {"order", 8}}, false);
  std::cerr << "serve: demo: job " << identify << " excites the transducer and identifies a linear model\n";
  if (!follow_job(server, identify, "demo " + identify)) return;
  const std::string plant_model = server.jobs().get(identify)->result.at("model_id").get<std::string>();
  nlohmann::json design_params = {{"plant_model", plant_model}};
  if (program_peak > 0.0) design_params["max_input"] = program_peak;
  const std::string design = server.submit_job("design-lq", design_params, true);
  std::cerr << "serve: demo: job " << design << " designs the LQ feedforward on " << plant_model
            << (program_peak > 0.0 ? " for a safe amplitude of the program's peak, " + models::number_text(program_peak) : "")
            << "\n";
  if (!follow_job(server, design, "demo " + design)) return;
  std::cerr << "serve: demo: done; the LQ feedforward "
            << server.jobs().get(design)->result.at("model_id").get<std::string>() << " plays in the chain\n";
}

void run_serve(const ServeOptions& o) {
  api::ServerOptions options;
  options.bind = o.bind;
  options.port = o.port;
  options.token = o.token;
  options.allowed_origins = o.allow_origins;
  options.allowed_hosts = o.allow_hosts;
  options.store = o.store;
  options.web_root = o.web;
  options.workers = o.workers;
  options.body_limit = o.body_limit_mib << 20;
  options.engine.plant = models::plant_from_name_or_file(o.plant);
  options.engine.chain.fs = options.engine.plant.fs;
  options.engine.seed = o.seed + 1;
  options.engine.realtime_priority = o.realtime_priority;
  const bool on_card = o.backend == "alsa";
  // The program at the rate it is played at: the chain's on the virtual transducer, the card's on ALSA.
  LoopedProgram looped =
      looped_program("", "0", o.signal, o.amplitude, o.seed, on_card ? o.alsa.rate : options.engine.plant.fs);
  std::vector<double> program = std::move(looped.samples);
  // GET /api/program's words for it, as PUT /api/program would say them.
  nlohmann::json& described = options.engine.program_description;
  described = {{"signal", o.signal}, {"amplitude", o.signal == "silence" ? 0.0 : o.amplitude}};
  if (o.signal == "noise") described["seed"] = o.seed;
  if (looped.description.contains("frequency_hz")) described["frequency_hz"] = looped.description["frequency_hz"];
  if (on_card) {
    options.engine.alsa = alsa_options_of(o.alsa);
    options.engine.alsa->realtime_priority = o.realtime_priority;
    options.engine.safe_level = o.safe_level;
    if (o.alsa.program_channel == engine::kNoChannel) options.engine.alsa->program = std::move(program);
  } else {
    options.engine.program = std::move(program);
  }
  options.log = [](const std::string& line) { std::cerr << "serve: " << line << "\n"; };
  if (!o.web.empty() && !std::filesystem::is_directory(o.web)) {
    throw std::invalid_argument("--web " + o.web + ": no such folder (run scripts/web_setup.sh, or --web \"\" for no UI)");
  }

  const StopSignals signals;
  api::Server server(options);
  server.start();
  // The address first, on stdout, so that scripts and tests can read it.
  std::cout << "panelbass: serving " << server.address() << " (store " << o.store << ")" << std::endl;
  std::thread demo;
  if (o.demo && on_card) {
    std::cerr << "serve: no demo on a sound card (start the tune from the web UI once the transducer is connected)\n";
  } else if (o.demo) {
    const double program_peak = o.signal == "silence" ? 0.0 : o.amplitude;
    demo = std::thread([&server, program_peak] { run_demo(server, program_peak); });
  }
  const auto started = std::chrono::steady_clock::now();
  while (!stop_requested() &&
         (o.seconds <= 0.0 ||
          std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count() < o.seconds)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  std::cerr << "serve: stopping\n";
  server.stop();
  if (demo.joinable()) demo.join();
}

}  // namespace

void register_serve(CLI::App& app) {
  auto o = std::make_shared<ServeOptions>();
  CLI::App* cmd = app.add_subcommand(
      "serve", "Run the engine (virtual transducer or sound card) with the HTTP API and the web UI (Ctrl-C to stop)");
  cmd->add_option("--bind", o->bind, "Address to listen on (beyond loopback only with --token)")->capture_default_str();
  cmd->add_option("--port", o->port, "Port (0: any free port; the address is printed first)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  cmd->add_option("--token", o->token, "Require Authorization: Bearer TOKEN on /api and /metrics");
  cmd->add_option("--allow-origin", o->allow_origins,
                  "An origin besides the server's own whose pages may change its state, e.g. https://panel.example "
                  "(repeatable; other origins get 403)");
  cmd->add_option("--allow-host", o->allow_hosts,
                  "A Host name besides localhost and the bound address that the server answers to, e.g. the name "
                  "a reverse proxy forwards (repeatable; other names get 421)");
  cmd->add_option("--store", o->store, "Folder of the model store (created if missing)")->capture_default_str();
  cmd->add_option("--web", o->web, "Folder of the web UI (\"\": no UI; default: the installed one, or the source tree's)")
      ->capture_default_str();
  cmd->add_option("--backend", o->backend, "virtual: the simulated transducer in-process; alsa: a sound card")
      ->check(CLI::IsMember({"virtual", "alsa"}))
      ->capture_default_str();
  cmd->add_option("--plant", o->plant,
                  "The virtual transducer: preset (panel-exciter, linear) or plant JSON file (on ALSA: sets the "
                  "chain's rate)")
      ->capture_default_str();
  cmd->add_option("--signal", o->signal, "Program the engine loops: noise, silence or sine:HZ")->capture_default_str();
  cmd->add_option("--amplitude", o->amplitude, "Peak of --signal, within (0, 1]")
      ->check(CLI::Range(1e-12, 1.0))
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the noise program (the transducer's sensor noise uses seed + 1)")
      ->capture_default_str();
  cmd->add_option("--workers", o->workers, "Job worker threads")->check(CLI::Range(1, 64))->capture_default_str();
  cmd->add_option("--body-limit", o->body_limit_mib, "Largest request body, MiB")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  cmd->add_flag("--demo,!--no-demo", o->demo,
                "At start-up: excite, identify a linear model, design the LQ feedforward whose safe amplitude is "
                "the program's --amplitude, and activate it")
      ->capture_default_str();
  cmd->add_option("--seconds", o->seconds, "Stop after this long (default: until SIGINT/SIGTERM)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--realtime-priority", o->realtime_priority,
                  "SCHED_FIFO priority of the audio thread, 1..99 (0: normal scheduling; status says if granted)")
      ->check(CLI::Range(0, 99))
      ->capture_default_str();
  add_alsa_options(cmd, o->alsa);
  cmd->add_option("--safe-level", o->safe_level,
                  "ALSA: the largest drive peak a measurement plays through the card (the exciter's safe level)")
      ->check(CLI::Range(1e-6, 1.0))
      ->capture_default_str();
  cmd->footer(
      "Examples:\n  panelbass serve                      (http://127.0.0.1:8080/, demo jobs at start-up)\n"
      "  panelbass serve --port 0 --no-demo --store /tmp/store\n"
      "  panelbass --config /etc/panelbass/panelbass.conf serve   (as the installed systemd unit does: its\n"
      "      [serve] section holds these options as key = value, e.g. port = 8080)\n"
      "  panelbass serve --backend alsa --playback hw:1 --capture hw:1 --sensor-channel 1 --period 64\n"
      "  panelbass serve --bind 0.0.0.0 --token s3cret      (clients send Authorization: Bearer s3cret)");
  cmd->callback([o] { run_serve(*o); });
}

}  // namespace panelbass::cli

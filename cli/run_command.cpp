// `panelbass run`: a chain file on a live backend until interrupted (SIGINT/SIGTERM) or for a set time,
// then the engine's metrics as one JSON object.
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "cli/alsa_options.h"
#include "cli/commands.h"
#include "models/io/number_text.h"
#include "cli/json_output.h"
#include "cli/looped_program.h"
#include "cli/stop_signals.h"
#include "dsp/excitation.h"
#include "dsp/resample.h"
#include "dsp/sample_rate.h"
#include "dsp/wav_file.h"
#include "engine/alsa_backend.h"
#include "api/alsa_status_json.h"
#include "engine/chain_file.h"
#include "api/metrics_json.h"
#include "engine/virtual_backend.h"
#include "models/plant/plant_presets.h"

namespace panelbass::cli {
namespace {

struct RunOptions {
  std::string chain;
  std::string backend = "virtual";
  std::string plant = "panel-exciter";
  std::string program;
  std::string channel = "0";
  std::string signal = "noise";
  double amplitude = 0.3;
  double seconds = 0.0;
  std::uint64_t seed = 1;
  int realtime_priority = 0;
  AlsaCliOptions alsa;
};

// Runs until a stop signal or `seconds` (0: no limit), freeing retired stages now and then.
double wait_for_stop(double seconds, engine::Chain& chain) {
  using clock = std::chrono::steady_clock;
  const auto started = clock::now();
  for (;;) {
    const double elapsed = std::chrono::duration<double>(clock::now() - started).count();
    if (stop_requested() || (seconds > 0.0 && elapsed >= seconds)) return elapsed;
    const double left = seconds > 0.0 ? seconds - elapsed : 0.05;
    std::this_thread::sleep_for(std::chrono::duration<double>(std::min(0.05, left)));
    chain.collect_retired();
  }
}

void run_virtual(const RunOptions& o, const engine::ChainConfig& config, nlohmann::json& result) {
  const models::PlantConfig plant = models::plant_from_name_or_file(o.plant);
  if (!dsp::same_rate(plant.fs, config.fs)) {
    throw std::invalid_argument("--plant " + o.plant + ": the plant runs at " + models::number_text(plant.fs) +
                                " Hz, the chain (" + o.chain + ") at " + models::number_text(config.fs) + " Hz");
  }
  LoopedProgram program = looped_program(o.program, o.channel, o.signal, o.amplitude, o.seed, config.fs);
  std::unique_ptr<engine::Chain> chain = engine::make_chain(config);
  engine::VirtualBackendOptions options;
  options.block = engine::Samples{config.block};
  options.pacing = engine::Pacing::real_time;
  options.program = std::move(program.samples);
  options.loop = true;
  options.plant = plant;
  options.noise_seed = o.seed + 1;
  options.realtime_priority = o.realtime_priority;
  engine::VirtualBackend backend(*chain, std::move(options));

  const StopSignals signals;
  std::cerr << "run: " << o.chain << " on the virtual transducer " << plant.name << " at " << config.fs
            << " Hz, block " << config.block << (o.seconds > 0.0 ? "" : "; Ctrl-C to stop") << "\n";
  backend.start();
  const double elapsed = wait_for_stop(o.seconds, *chain);
  backend.stop();
  chain->collect_retired();
  std::cerr << "run: stopped after " << elapsed << " s\n";

  result["plant"] = plant.name;
  result["realtime"] = backend.realtime();
  result["program"] = program.description;
  result["seconds"] = elapsed;
  result["interrupted"] = stop_requested();
  result["metrics"] = api::metrics_to_json(chain->metrics().snapshot());
}

void run_alsa(const RunOptions& o, const engine::ChainConfig& config, nlohmann::json& result) {
  const AlsaCliOptions& a = o.alsa;
  if (config.feedback && config.feedback->source == engine::FeedbackSource::sensor &&
      a.sensor_channel == engine::kNoChannel) {
    throw std::invalid_argument(o.chain + ": feedback.source is \"sensor\" but no --sensor-channel is given");
  }
  engine::AlsaOptions options = alsa_options_of(a);
  options.realtime_priority = o.realtime_priority;
  nlohmann::json program_description = {{"capture_channel", a.program_channel}};
  if (a.program_channel == engine::kNoChannel) {
    // The program is played from memory at the device's rate.
    LoopedProgram program = looped_program(o.program, o.channel, o.signal, o.amplitude, o.seed, a.rate);
    options.program = std::move(program.samples);
    program_description = program.description;
  }
  options.loop_program = true;
  std::unique_ptr<engine::Chain> chain = engine::make_chain(config);
  engine::AlsaBackend backend(*chain, std::move(options));

  const StopSignals signals;
  std::cerr << "run: " << o.chain << " on ALSA (playback \"" << a.playback << "\", capture \"" << a.capture << "\") at "
            << a.rate << " Hz, period " << a.period << ", chain at " << config.fs << " Hz"
            << (o.seconds > 0.0 ? "" : "; Ctrl-C to stop") << "\n";
  backend.start();
  const double elapsed = wait_for_stop(o.seconds, *chain);
  const engine::AlsaStatus status = backend.status();
  backend.stop();
  chain->collect_retired();
  std::cerr << "run: stopped after " << elapsed << " s\n";
  if (status.opens == 0) {
    throw std::runtime_error("--backend alsa: the devices never opened (playback \"" + a.playback + "\", capture \"" +
                             a.capture + "\"): " + std::string(status.last_error.data()));
  }
  result["program"] = program_description;
  result["seconds"] = elapsed;
  result["interrupted"] = stop_requested();
  result["alsa"] = api::alsa_status_to_json(status, backend.resampling_latency());
  result["metrics"] = api::metrics_to_json(chain->metrics().snapshot());
}

void run_run(const RunOptions& o) {
  const engine::ChainConfig config = engine::load_chain_file(o.chain);
  nlohmann::json result = {{"chain", o.chain}, {"backend", o.backend}, {"fs", config.fs}, {"block", config.block}};
  if (o.backend == "alsa") {
    run_alsa(o, config, result);
  } else {
    run_virtual(o, config, result);
  }
  print_result(result);
}

}  // namespace

void register_run(CLI::App& app) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand(
      "run", "Run a chain file on a live backend until interrupted (or --seconds), then print the metrics");
  cmd->add_option("--chain", o->chain, "Chain file (panelbass.chain/1)")->required();
  cmd->add_option("--backend", o->backend, "virtual: the simulated transducer in-process; alsa: a sound card")
      ->check(CLI::IsMember({"virtual", "alsa"}))
      ->capture_default_str();
  cmd->add_option("--plant", o->plant, "Virtual backend: preset (panel-exciter, linear) or plant JSON file")
      ->capture_default_str();
  CLI::Option* program = cmd->add_option("--program", o->program, "Program input: a WAV file, looped (any rate)");
  cmd->add_option("--channel", o->channel, "Channel of --program: zero-based index or name")->capture_default_str();
  cmd->add_option("--signal", o->signal, "Program input when no --program: noise, silence or sine:HZ")
      ->capture_default_str()
      ->excludes(program);
  cmd->add_option("--amplitude", o->amplitude, "Peak of --signal, within (0, 1]")
      ->check(CLI::Range(1e-12, 1.0))
      ->capture_default_str();
  cmd->add_option("--seconds", o->seconds, "Stop after this long (default: run until SIGINT/SIGTERM)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--seed", o->seed, "Seed of the noise signal (the plant's sensor noise uses seed + 1)")
      ->capture_default_str();
  cmd->add_option("--realtime-priority", o->realtime_priority,
                  "SCHED_FIFO priority of the audio thread, 1..99 (0: normal scheduling)")
      ->check(CLI::Range(0, 99))
      ->capture_default_str();
  add_alsa_options(cmd, o->alsa);
  cmd->footer(
      "Examples:\n  panelbass run --chain chain.json --backend virtual --signal sine:80 --amplitude 0.5 --seconds 10\n"
      "  panelbass run --chain chain.json --backend virtual --program music.wav     (Ctrl-C to stop)\n"
      "  panelbass run --chain chain.json --backend alsa --playback hw:1 --capture hw:1 --rate 48000 --period 64 \\\n"
      "      --sensor-channel 1 --program music.wav");
  cmd->callback([o] { run_run(*o); });
}

}  // namespace panelbass::cli

#pragma once
// A JACK server with the dummy driver (Debian jackd2), started and stopped by a test, and an in-memory
// ALSA configuration of two PCMs of type "jack" (Debian libasound2-plugins) wired as a loopback: what is
// played on the drive port comes back on the capture's channel 1. Used by the ALSA backend's tests and by
// the server's test on a sound card.

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "engine/alsa_backend.h"

extern char** environ;

namespace panelbass::testing_support {

/// True when PANELBASS_SKIP_JACK=1 asks to skip the JACK tests.
inline bool skip_jack() {
  const char* v = std::getenv("PANELBASS_SKIP_JACK");
  return v != nullptr && std::string(v) == "1";
}

/// The first executable `name` on PATH ("" if none).
inline std::string find_on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path != nullptr ? path : "/usr/bin:/bin");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const std::string candidate = dir + "/" + name;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return "";
}

/// A JACK server with the dummy driver, started and stopped by the test.
class JackServer {
 public:
  /// A server named `name` running the dummy driver at `rate` Hz with `period`-frame periods (not started).
  JackServer(std::string name, double rate, int period)
      : name_(std::move(name)),
        rate_(rate),
        period_(period),
        log_(std::filesystem::temp_directory_path() / ("panelbass-" + name_ + ".log")),
        socket_(std::string("/dev/shm/jack_") + name_ + "_" + std::to_string(::getuid()) + "_0") {}
  ~JackServer() {
    stop();
    std::error_code ignored;
    std::filesystem::remove(log_, ignored);
  }

  /// Starts jackd and waits until its socket is there; "" on success, else what went wrong.
  std::string start() {
    const std::string jackd = find_on_path("jackd");
    if (jackd.empty()) {
      return "jackd is not on PATH: install the Debian packages jackd2 and libasound2-plugins "
             "(scripts/bootstrap.sh installs them), or set PANELBASS_SKIP_JACK=1 to skip this test";
    }
    // No D-Bus device reservation in a container; the server must not look for one.
    ::setenv("JACK_NO_AUDIO_RESERVATION", "1", 1);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log_.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    const std::string rate = std::to_string(static_cast<int>(rate_)), period = std::to_string(period_);
    // --no-realtime: no real-time scheduling needed (nor asked for) in a container. -S (synchronous
    // mode): the server waits for every client each cycle, so on a loaded machine a late client delays
    // the cycle instead of being skipped for it, which would slip the capture against the playback.
    std::vector<std::string> args = {jackd, "--no-realtime", "-S", "-n", name_, "-d", "dummy", "-r", rate, "-p", period};
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    const int err = posix_spawn(&pid_, jackd.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (err != 0) {
      pid_ = -1;
      return "cannot spawn " + jackd + ": " + std::strerror(err);
    }
    for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5); std::chrono::steady_clock::now() < until;) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return "jackd exited at start-up (status " + std::to_string(status) + "); its output:\n" + log();
      }
      if (std::filesystem::exists(socket_)) return "";
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    stop();
    return "jackd did not open its socket " + socket_ + " within 5 s; its output:\n" + log();
  }

  /// Makes this server the one every JACK client of the process connects to (JACK_DEFAULT_SERVER), then
  /// start(); "" on success, else what went wrong.
  std::string start_as_default() {
    ::setenv("JACK_DEFAULT_SERVER", name_.c_str(), 1);
    return start();
  }

  /// Stops the server (SIGTERM, then SIGKILL after 3 s) and waits for it.
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    int status = 0;
    for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(3); std::chrono::steady_clock::now() < until;) {
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }

  /// What the server printed so far (its last 2000 characters).
  std::string log() const {
    std::ifstream in(log_);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return text.size() > 2000 ? text.substr(text.size() - 2000) : text;
  }
  /// The server's name.
  const std::string& name() const { return name_; }

 private:
  std::string name_;
  double rate_;
  int period_;
  std::filesystem::path log_;
  std::string socket_;
  pid_t pid_ = -1;
};

/// The in-memory ALSA configuration: a playback PCM whose two ports go to the dummy card, and a capture
/// PCM whose channel 0 listens to the dummy card (silence) and channel 1 to the playback's drive port.
/// The capture connects when it starts, after the playback (the backend starts them in that order).
inline std::string loopback_config(const std::string& tag) {
  return "pcm.pb_play {\n"
         "  type jack\n"
         "  name \"" + tag + "p\"\n"
         "  playback_ports { 0 \"system:playback_1\" 1 \"system:playback_2\" }\n"
         "}\n"
         "pcm.pb_capture {\n"
         "  type jack\n"
         "  name \"" + tag + "c\"\n"
         "  capture_ports { 0 \"system:capture_1\" 1 \"" + tag + "p:out_000\" }\n"
         "}\n";
}

/// The card the JACK tests run: 48 kHz, 64-frame periods (a common sound card's set-up).
inline constexpr double kDeviceRate = 48000.0;
/// The JACK tests' period, in frames.
inline constexpr int kPeriod = 64;

/// The ALSA options of the tests' JACK card: the PCMs pb_play and pb_capture of `config_text`
/// (loopback_config or a test's own), `rate` Hz, `periods` periods of `period` frames, a modest SCHED_FIFO
/// priority where the machine grants it (root or CAP_SYS_NICE; else the buffer's slack has to do), and as
/// the program one second of a `sine_hz` sine at `level`, looped. A test sets its channels.
inline engine::AlsaOptions jack_card(std::string config_text, double rate, int period, int periods, double level,
                                     double sine_hz = 60.0) {
  engine::AlsaOptions o;
  o.config_text = std::move(config_text);
  o.playback_device = "pb_play";
  o.capture_device = "pb_capture";
  o.rate = engine::Hertz{rate};
  o.period = engine::Samples{period};
  o.periods = periods;
  o.realtime_priority = 20;
  o.program.assign(static_cast<std::size_t>(rate), 0.0);
  for (std::size_t k = 0; k < o.program.size(); ++k) {
    o.program[k] = level * std::sin(2.0 * 3.141592653589793 * sine_hz * static_cast<double>(k) / rate);
  }
  return o;
}

}  // namespace panelbass::testing_support

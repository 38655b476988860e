// Load on the HTTP API while the engine plays: `panelbass serve` in-process on the virtual transducer
// (real-time pacing), several loopback clients issuing a mix of reads, uploads and activations. Prints
// one JSON object: requests, failures, latency percentiles, and the engine's xruns, faults and swaps.
//
//   build/bin/api_load_bench [--requests 12000] [--connections 4] [--seed 1]
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "api/server.h"
#include "dsp/excitation.h"
#include "dsp/random.h"
#include "models/control/lq_feedforward.h"
#include "models/linear/linear_model.h"
#include "models/plant/plant_presets.h"
#include "models/linear/transfer_function.h"

// After Eigen: glibc's <resolv.h>, which cpp-httplib includes, defines the macro _res that Eigen uses as a name.
#include <httplib.h>

namespace {

using namespace panelbass;

// A stable second-order model whose coefficients depend on `k` (so every upload is a new model).
models::LinearModel numbered_linear(int k) {
  models::LinearModel m;
  Eigen::VectorXcd poles(2);
  const double theta = 0.1 + 0.5 * (k % 997) / 997.0;
  poles << std::polar(0.9, theta), std::polar(0.9, -theta);
  m.tf.a = models::polynomial_from_roots(poles).tail(2);
  m.tf.b = Eigen::Vector2d(0.05 + 1e-4 * k, 0.02);
  m.tf.nk = 1;
  m.fs = 3000.0;
  return m;
}

// numbered_linear(k) as a model file.
nlohmann::json numbered_model(int k) { return models::linear_model_to_json(numbered_linear(k)); }

// An LQ feedforward controller designed on numbered_linear(k): what the feedforward slot runs.
nlohmann::json numbered_controller(int k) {
  return models::lq_feedforward_to_json(models::design_lq(numbered_linear(k), {3.0, 20.0}));
}

struct Options {
  int requests = 12000;
  int connections = 4;
  std::uint64_t seed = 1;
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    if (key == "--requests") o.requests = std::stoi(argv[i + 1]);
    else if (key == "--connections") o.connections = std::stoi(argv[i + 1]);
    else if (key == "--seed") o.seed = std::stoull(argv[i + 1]);
    else throw std::invalid_argument("unknown option " + key + " (expected --requests, --connections, --seed)");
  }
  return o;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

}  // namespace

int main(int argc, char** argv) try {
  const Options o = parse(argc, argv);
  const std::filesystem::path store =
      std::filesystem::temp_directory_path() / ("panelbass-load-" + std::to_string(::getpid()));
  api::ServerOptions options;
  options.port = 0;
  options.store = store;
  options.engine.plant = models::plant_preset("panel-exciter");
  options.engine.chain.fs = options.engine.plant.fs;
  const Eigen::VectorXd program = dsp::uniform_noise(30000, 0.2, o.seed);
  options.engine.program.assign(program.data(), program.data() + program.size());
  options.http_threads = o.connections + 4;
  api::Server server(options);
  const int port = server.start();

  // Two controllers to activate in turn, stored before the load starts.
  std::vector<std::string> active_pool;
  {
    httplib::Client c("127.0.0.1", port);
    for (int k = 0; k < 2; ++k) {
      const auto r = c.Post("/api/models", numbered_controller(100000 + k).dump(), "application/json");
      if (!r || (r->status != 201 && r->status != 200)) throw std::runtime_error("setup upload failed");
      active_pool.push_back(nlohmann::json::parse(r->body)["id"]);
    }
  }

  std::atomic<int> next{0}, failures{0}, uploads{0}, activations{0}, reads{0};
  std::mutex latencies_mutex;
  std::vector<double> latencies_ms;
  std::vector<std::string> failure_examples;
  const auto started = std::chrono::steady_clock::now();
  std::vector<std::thread> clients;
  for (int c = 0; c < o.connections; ++c) {
    clients.emplace_back([&, c] {
      httplib::Client client("127.0.0.1", port);
      client.set_keep_alive(true);
      client.set_tcp_nodelay(true);
      dsp::Rng rng(o.seed * 1000 + static_cast<std::uint64_t>(c));
      std::vector<double> mine;
      for (int k = next++; k < o.requests; k = next++) {
        const double pick = rng.uniform(0.0, 1.0);
        const auto t0 = std::chrono::steady_clock::now();
        int expected = 200;
        const httplib::Result r = [&] {
          if (pick < 0.10) {
            expected = 201;
            ++uploads;
            return client.Post("/api/models", numbered_model(k).dump(), "application/json");
          }
          if (pick < 0.20) {
            ++activations;
            const std::string& id = active_pool[static_cast<std::size_t>(k) % 2];
            return client.Post(("/api/models/" + id + "/activate").c_str(), "", "application/json");
          }
          static const char* const paths[] = {"/api/status", "/api/models", "/api/config", "/api/jobs", "/metrics"};
          ++reads;
          return client.Get(paths[static_cast<std::size_t>(k) % 5]);
        }();
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        mine.push_back(ms);
        if (!r || r->status != expected) {
          ++failures;
          const std::lock_guard lock(latencies_mutex);
          if (failure_examples.size() < 5) {
            failure_examples.push_back(r ? std::to_string(r->status) + " " + r->body : "transport error");
          }
        }
      }
      const std::lock_guard lock(latencies_mutex);
      latencies_ms.insert(latencies_ms.end(), mine.begin(), mine.end());
    });
  }
  for (std::thread& t : clients) t.join();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  const engine::MetricsSnapshot m = server.engine().metrics();
  server.stop();
  std::filesystem::remove_all(store);

  const nlohmann::json out = {
      {"requests", o.requests},
      {"connections", o.connections},
      {"reads", reads.load()},
      {"uploads", uploads.load()},
      {"activations", activations.load()},
      {"failed", failures.load()},
      {"failure_examples", failure_examples},
      {"seconds", seconds},
      {"requests_per_second", o.requests / seconds},
      {"latency_ms", {{"p50", percentile(latencies_ms, 0.50)}, {"p99", percentile(latencies_ms, 0.99)},
                      {"max", percentile(latencies_ms, 1.0)}}},
      {"engine", {{"blocks", m.blocks}, {"xruns", m.xruns}, {"faults", m.faults}, {"swaps", m.swaps},
                  {"p99_block_ns", m.p99_block_ns}, {"max_block_ns", m.max_block_ns}}}};
  std::cout << out.dump(2) << std::endl;
  return failures.load() == 0 ? 0 : 1;
} catch (const std::exception& e) {
  std::cerr << "api_load_bench: " << e.what() << std::endl;
  return 1;
}

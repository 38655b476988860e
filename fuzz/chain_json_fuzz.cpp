// libFuzzer target: chain (engine configuration) files (engine/chain_file.h chain_config_from_json), with
// model paths relative to an empty folder. The input bytes are parsed as JSON first; a bad chain must be a
// ConfigError naming the key path, never a crash or any other exception. A chain that passes must read
// back as itself from its JSON form, compare equal to itself with no change classified, and build.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <system_error>

#include "fuzz/scratch_file.h"
#include "engine/chain_file.h"
#include "models/io/config_error.h"

namespace {

namespace fs = std::filesystem;

using panelbass::fuzz::scratch_base;

/// An empty folder in memory-backed /dev/shm (the system temp folder if there is none), one per process.
const fs::path& empty_folder() {
  static const fs::path path = [] {
    const fs::path base = scratch_base();
    const fs::path folder = base / ("panelbass-chain-fuzz-" + std::to_string(::getpid()));
    fs::create_directories(folder);
    std::atexit([] { std::error_code ignored; fs::remove_all(empty_folder(), ignored); });
    return folder;
  }();
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace panelbass::engine;
  const nlohmann::json json = nlohmann::json::parse(data, data + size, nullptr, false);
  if (json.is_discarded()) return 0;
  ChainConfig config;
  try {
    config = chain_config_from_json(json, empty_folder());
  } catch (const panelbass::models::ConfigError&) {
    return 0;
  }
  const ChainConfig again = chain_config_from_json(chain_config_to_json(config), empty_folder());
  if (!(again == config)) std::abort();  // a written chain must read back as itself
  if (classify_change(config, again).kind != ChangeClass::none) std::abort();
  // A validated chain must build: band-pass design, the slots' stages, their preparation.
  (void)make_chain(config);
  return 0;
}

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cli/band_pass_option.h"
#include "cli/commands.h"
#include "cli/json_output.h"
#include "engine/chain_file.h"
#include "models/io/json_file.h"

namespace panelbass::cli {
namespace {

struct ChainCommandOptions {
  std::string bandpass = "20,1200";
  int order = 2;
  std::string ff, fb, source = "model", out;
  double fs = 3000.0;
  int block = 64;
  double crossfade_ms = 20.0;
};

// A model path as the chain file will hold it: relative to the chain file's folder.
std::string relative_to(const std::string& model, const std::filesystem::path& chain_folder) {
  return std::filesystem::relative(std::filesystem::absolute(model), std::filesystem::absolute(chain_folder)).string();
}

void run_chain(const ChainCommandOptions& o) {
  std::filesystem::path folder = std::filesystem::path(o.out).parent_path();
  if (folder.empty()) folder = ".";
  const auto [low, high] = parse_bandpass(o.bandpass);
  nlohmann::json chain = {
      {"format", engine::kChainFormat},
      {"fs", o.fs},
      {"block", o.block},
      {"band_pass", {{"low_hz", low}, {"high_hz", high}, {"order", o.order}}},
      {"crossfade_ms", o.crossfade_ms},
  };
  if (!o.ff.empty()) chain["feedforward"] = {{"model", relative_to(o.ff, folder)}};
  if (!o.fb.empty()) chain["feedback"] = {{"model", relative_to(o.fb, folder)}, {"source", o.source}};
  // Validated exactly as the engine will read it (models loaded, rates and kinds checked) before writing.
  const engine::ChainConfig config = engine::chain_config_from_json(chain, folder);
  const nlohmann::json written = engine::chain_config_to_json(config);
  models::write_json_file(o.out, written);
  print_result({{"chain", o.out}, {"config", written}});
}

}  // namespace

void register_chain(CLI::App& app) {
  auto o = std::make_shared<ChainCommandOptions>();
  CLI::App* cmd = app.add_subcommand("chain", "Write the chain file the engine runs: band-pass, feedforward, feedback");
  add_bandpass_option(cmd, o->bandpass, "Band-pass corners LO,HI in Hz (LO = 0: low-pass only)");
  cmd->add_option("--order", o->order, "Order of the band-pass's high-pass and low-pass")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  cmd->add_option("--ff", o->ff, "Feedforward controller (design lq) or linear model file");
  cmd->add_option("--fb", o->fb, "Feedback controller (design nn) or NARX model file");
  cmd->add_option("--source", o->source, "Where the feedback stage reads the plant output")
      ->check(CLI::IsMember({"model", "sensor"}))
      ->capture_default_str();
  cmd->add_option("--fs", o->fs, "Rate the chain runs at, Hz (the models' rate)")->capture_default_str();
  cmd->add_option("--block", o->block, "Block length")->check(CLI::Range(1, 8192))->capture_default_str();
  cmd->add_option("--crossfade-ms", o->crossfade_ms, "Crossfade of a model swap, ms")->capture_default_str();
  cmd->add_option("--out", o->out, "Chain file to write (JSON)")->required();
  cmd->footer("Example:\n  panelbass chain --bandpass 20,1200 --ff ff.json --fb fb.json --out chain.json");
  cmd->callback([o] { run_chain(*o); });
}

}  // namespace panelbass::cli

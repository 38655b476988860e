#pragma once
// Offline rendering: program input → chain → drive, block by block through exactly the code the
// real-time backends run, as fast as the CPU allows; with a plant, the simulated transducer output too.

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "engine/chain.h"
#include "models/plant/plant_config.h"

namespace panelbass::engine {

/// How to render.
struct RenderOptions {
  Samples block{64};                         ///< block length (≤ the chain's max_block)
  std::optional<models::PlantConfig> plant;  ///< with a plant: closed loop, its measured output rendered
  std::uint64_t noise_seed = 1;              ///< the plant's sensor noise seed
};

/// What a rendering produced.
struct Rendering {
  Eigen::VectorXd drive;     ///< the chain's output, within [−1, 1]
  Eigen::VectorXd measured;  ///< the plant's measured output (empty without a plant)
  Eigen::VectorXd clean;     ///< the same without the sensor's noise: what the transducer did (empty without a plant)
};

/// Runs `program` through `chain` from its current state; throws std::invalid_argument for a block
/// length outside [1, max_block] or a plant whose fs differs from the chain's.
Rendering render(Chain& chain, const Eigen::VectorXd& program, const RenderOptions& options);

/// Reads channel `channel` of the WAV file `in`, renders it, and writes `out` (32-bit float) with the
/// columns "drive" and, with a plant, "y". Throws (naming the file) for an unreadable input or a sample
/// rate other than the chain's (resampling is not done here).
void render_file(const std::filesystem::path& in, const std::string& channel, const std::filesystem::path& out,
                 Chain& chain, const RenderOptions& options);

}  // namespace panelbass::engine

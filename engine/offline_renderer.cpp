#include "engine/offline_renderer.h"

#include <algorithm>
#include <cmath>
#include <span>
#include <stdexcept>
#include <string>

#include "dsp/sample_rate.h"
#include "dsp/wav_file.h"
#include "engine/closed_loop.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::engine {

Rendering render(Chain& chain, const Eigen::VectorXd& program, const RenderOptions& options) {
  const ProcessSpec& spec = chain.options().spec;
  if (options.block.value < 1 || options.block.value > spec.max_block) {
    throw std::invalid_argument("render: block must be within [1, " + std::to_string(spec.max_block) + "], got " +
                                std::to_string(options.block.value));
  }
  std::optional<models::VirtualTransducer> plant;
  if (options.plant) {
    if (!dsp::same_rate(options.plant->fs, spec.fs)) {
      throw std::invalid_argument("render: the plant runs at " + std::to_string(options.plant->fs) +
                                  " Hz, the chain at " + std::to_string(spec.fs) + " Hz");
    }
    plant.emplace(*options.plant, options.noise_seed);
  }
  Rendering r;
  r.drive = Eigen::VectorXd::Zero(program.size());
  if (plant) {
    r.measured = Eigen::VectorXd::Zero(program.size());
    r.clean = Eigen::VectorXd::Zero(program.size());
  }
  const auto total = static_cast<std::size_t>(program.size());
  for (std::size_t pos = 0; pos < total; pos += static_cast<std::size_t>(options.block.value)) {
    const std::size_t n = std::min(total - pos, static_cast<std::size_t>(options.block.value));
    const std::span<const double> in(program.data() + pos, n);
    const std::span<double> drive(r.drive.data() + pos, n);
    if (plant) {
      process_closed_loop(chain, *plant, in, drive, std::span<double>(r.measured.data() + pos, n),
                          std::span<double>(r.clean.data() + pos, n));
    } else {
      chain.process_block(in, drive);
    }
  }
  return r;
}

void render_file(const std::filesystem::path& in, const std::string& channel, const std::filesystem::path& out,
                 Chain& chain, const RenderOptions& options) {
  const dsp::Record input = dsp::read_wav(in, {channel});
  const double fs = chain.options().spec.fs;
  if (!dsp::same_rate(input.fs, fs)) {
    throw std::invalid_argument(in.string() + ": sample rate " + std::to_string(input.fs) +
                                " Hz, the chain runs at " + std::to_string(fs) + " Hz (no resampling yet)");
  }
  Rendering r = render(chain, input.columns.front(), options);
  dsp::Record output;
  output.fs = fs;
  output.add("drive", std::move(r.drive));
  if (r.measured.size() > 0) output.add("y", std::move(r.measured));
  dsp::write_wav(out, output, dsp::WavFormat::float32);
}

}  // namespace panelbass::engine

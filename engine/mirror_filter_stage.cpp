#include "engine/mirror_filter_stage.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace panelbass::engine {

MirrorFilterStage::MirrorFilterStage(const models::MirrorModel& model) : fs_(model.fs), filter_(model) {}

void MirrorFilterStage::prepare(const ProcessSpec& spec) {
  if (std::abs(spec.fs - fs_) > 1e-9 * fs_) {
    throw std::invalid_argument("mirror_filter: the model is for " + std::to_string(fs_) + " Hz, the chain runs at " +
                                std::to_string(spec.fs) + " Hz");
  }
  filter_.reset();
}

}  // namespace panelbass::engine

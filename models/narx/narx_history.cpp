#include "models/narx/narx_history.h"

#include "models/narx/narx_model.h"

namespace panelbass::models {

NarxHistory::NarxHistory(const NarxStructure& structure)
    : na_(structure.na),
      nb_(structure.nb),
      nk_(structure.nk),
      inputs_(static_cast<std::size_t>(structure.nk + structure.nb + 1)),
      outputs_(static_cast<std::size_t>(structure.na)),
      x_(Eigen::VectorXd::Zero(structure.inputs())) {}

const Eigen::VectorXd& NarxHistory::regressor() noexcept {
  fill_narx_regressor(
      na_, nb_, nk_, [this](int i) { return outputs_[static_cast<std::size_t>(i)]; },
      [this](int j) { return inputs_[static_cast<std::size_t>(j)]; }, x_);
  return x_;
}

void NarxHistory::reset() noexcept {
  inputs_.reset();
  outputs_.reset();
}

}  // namespace panelbass::models

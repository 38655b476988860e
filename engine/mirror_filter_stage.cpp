#include "engine/mirror_filter_stage.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace panelbass::engine {

MirrorFilterStage::MirrorFilterStage(const models::MirrorModel& model) : fs_(model.fs), filter_(model) {
  if (model.observer.enabled && model.observer.measurement == models::MirrorMeasurement::current) {
    adapter_.emplace(model);
  } else if (model.observer.enabled) {
    observer_.emplace(model);
  }
}

void MirrorFilterStage::prepare(const ProcessSpec& spec) {
  if (std::abs(spec.fs - fs_) > 1e-9 * fs_) {
    throw std::invalid_argument("mirror_filter: the model is for " + std::to_string(fs_) + " Hz, the chain runs at " +
                                std::to_string(spec.fs) + " Hz");
  }
  reset();
}

double MirrorFilterStage::process(double x) noexcept {
  const double drive = filter_.process(x);
  // the observer's model is driven by what the transducer gets: at most full scale (the limiter's bound)
  if (observer_) observer_->predict(std::clamp(drive, -1.0, 1.0));
  if (adapter_) adapter_->push_drive(std::clamp(drive, -1.0, 1.0));
  return drive;
}

void MirrorFilterStage::observe(double measured) noexcept {
  // a chain without a sensor observes exact zeros (Chain::process_block without one): nothing to adapt from, the
  // observer's model runs on without its measurement update
  if (measured == 0.0) return;
  if (adapter_) {
    adapter_->update(measured);
    if (++since_scales_ >= kScaleInterval) {
      since_scales_ = 0;
      filter_.set_scales(adapter_->scales());
    }
    return;
  }
  if (!observer_) return;
  observer_->update(measured);
  const models::MirrorScales scales = observer_->scales();
  filter_.set_scales(scales.stiffness, scales.force, scales.nonlinear);
}

void MirrorFilterStage::reset() noexcept {
  filter_.reset();
  if (observer_) observer_->reset();
  if (adapter_) adapter_->reset();
  if (observer_ || adapter_) filter_.set_scales(models::MirrorScales{});
  since_scales_ = 0;
}

}  // namespace panelbass::engine

#pragma once
// The chain and a simulated plant in one loop, sample by sample: the code that both the virtual
// backend and the offline renderer run, so that the two produce the same numbers.

#include <cstddef>
#include <span>

#include "engine/chain.h"
#include "models/plant/virtual_transducer.h"

namespace panelbass::engine {

/// One block of `chain` driving `plant`: each drive sample is stepped through the plant at once and
/// its measured output (also written to `measured`, as long as `program`) is what the stages observe
/// before the next sample. `clean`, when not empty (then as long as `program`), receives the output
/// without the sensor's noise. Allocation-free.
inline void process_closed_loop(Chain& chain, models::VirtualTransducer& plant, std::span<const double> program,
                                std::span<double> drive, std::span<double> measured,
                                std::span<double> clean = {}) noexcept {
  std::size_t k = 0;
  chain.process_block(program, drive, [&](double d) noexcept {
    const models::PlantSample s = plant.step(d);
    measured[k] = s.y;
    if (!clean.empty()) clean[k] = s.y_clean;
    ++k;
    return s.y;
  });
}

}  // namespace panelbass::engine

#pragma once
// The JSON form of a chain evaluation's rows and of its per-term attribution, as `panelbass evaluate` and the
// HTTP evaluate job both report them.

#include <nlohmann/json.hpp>
#include <vector>

#include "evaluation/chain_evaluation.h"
#include "evaluation/distortion_attribution.h"
#include "evaluation/level_sweep.h"

namespace panelbass::evaluation {

/// {"name","ripple_db","jc_pct" (the transducer's output without sensor noise),"measured_ripple_db",
/// "measured_jc_pct" (through the noisy sensor),"max_drive","rail_fraction","rest_drive_peak","faults","probes":[{"frequency_hz",
/// "amplitude","drive_peak","h2_db","h3_db","thd_pct","harmonics_db":[H2…] (null for an absent harmonic),
/// "model_thd_pct" (null without a neural feedback stage)}]}.
nlohmann::json evaluation_row_to_json(const EvaluationRow& row);

/// [{"term","rows":[evaluation_row_to_json…]}], one entry per term of attribute_distortion().
nlohmann::json attribution_to_json(const std::vector<TermDistortion>& terms);

/// {"curves":[{"frequency_hz","worst_cut_db","points":[{"program_amplitude","reachable","cut_db","noise_floor_pct",
/// "plant_drive","chain":{"fundamental","thd_pct","h2_db","h3_db","drive_peak"},"plant":{…}}]}],"imd":[{"program_amplitude",
/// "output_low","chain_imd_pct","plant_scale","plant_imd_pct","cut_db","reachable"}]}; null for a number that is not finite.
nlohmann::json level_sweep_to_json(const LevelSweep& sweep);

}  // namespace panelbass::evaluation

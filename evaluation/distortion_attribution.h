#pragma once
// Which physics makes a chain's distortion on a virtual transducer: the evaluation repeated on copies of the
// plant with one nonlinear term left on at a time. The mission's "say why, in physics" for the table a
// controller is judged by: a probe whose harmonics the feedback does not cut is traced to the term that
// makes them (on panel-exciter behind band-pass + LQ: the Coulomb friction at 160 Hz).

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "evaluation/chain_evaluation.h"
#include "engine/chain_file.h"
#include "models/plant/plant_config.h"

namespace panelbass::evaluation {

/// The evaluation's rows on the plant with only one nonlinear term on.
struct TermDistortion {
  std::string term;                 ///< the term's name in the plant file ("friction")
  std::vector<EvaluationRow> rows;  ///< evaluate_chain's rows "plant" and "band-pass + feedforward" on that plant
};

/// evaluate_chain() on `plant` with each of its enabled nonlinear terms alone (every other term off, the
/// linear part unchanged), in NonlinearTerms' order; `progress(done, total, term)` is called before each.
/// The probes' program amplitudes are set by band-pass + feedforward, so they are the same in every copy
/// and the rows compare term by term. The chain's feedback stage is left out: it is designed to cancel the
/// whole plant's distortion, so on a plant with one term its correction is itself distortion; what it is
/// there to remove is the band-pass + feedforward row's. Throws as evaluate_chain().
std::vector<TermDistortion> attribute_distortion(
    const ChainConfig& config, const models::PlantConfig& plant, const EvaluationOptions& options,
    const std::function<void(std::size_t done, std::size_t total, const std::string& term)>& progress = {});

}  // namespace panelbass::evaluation

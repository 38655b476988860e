#include "evaluation/distortion_attribution.h"

namespace panelbass::evaluation {

std::vector<TermDistortion> attribute_distortion(
    const ChainConfig& config, const models::PlantConfig& plant, const EvaluationOptions& options,
    const std::function<void(std::size_t, std::size_t, const std::string&)>& progress) {
  const std::vector<std::string> terms = models::enabled_nonlinear_terms(plant);
  ChainConfig without_feedback = config;
  without_feedback.feedback.reset();
  std::vector<TermDistortion> result;
  for (const std::string& term : terms) {
    if (progress) progress(result.size(), terms.size(), term);
    models::PlantConfig only = models::with_only_term(plant, term);
    only.name = plant.name + " (only " + term + ")";
    result.push_back({term, evaluate_chain(without_feedback, only, options).rows});
  }
  return result;
}

}  // namespace panelbass::evaluation

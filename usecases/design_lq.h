#pragma once
// `design lq` / the design-lq job: the LQ feedforward controller of [7A]/[7B] behind a Butterworth band-pass,
// tracking a flat response or a target band, with its safe program amplitude. One request, its defaults written
// once; both doors fill it and print or store the report.

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "models/control/lq_feedforward.h"
#include "models/linear/linear_model.h"
#include "usecases/band_pass.h"
#include "usecases/progress.h"

namespace panelbass::usecases {

/// The desired response's band instead of a flat one: a Butterworth high-pass, flat above.
struct TargetHighpass {
  double hz = 0.0;  ///< its corner, in (0, band_pass.high_hz)
  int order = 2;    ///< 1..8
};

/// What `design lq` is asked.
struct DesignLqRequest {
  nlohmann::json plant_model;  ///< the plant model file object: linear; gray_box (its linear part); ss (linearised at rest)
  std::string plant_name;      ///< where it came from (a path, a stored id), kept in the controller's meta
  std::optional<double> r;     ///< weight on u* (> 0); models::LqWeights's unless max_input is given
  std::optional<double> max_input;  ///< instead of r: the program peak (0, 1] band-limited noise may have; r searched
  double r0 = models::LqWeights{}.R0;  ///< weight on the model output (≥ 0)
  BandPass band_pass;                  ///< in front of the controller
  std::optional<TargetHighpass> target_highpass;  ///< none: the thesis's flat response
  long noise_samples = 100000;  ///< uniform noise behind the safe amplitude, samples
  std::uint64_t seed = 1;       ///< of that noise
};

/// What `design lq` made.
struct DesignLqReport {
  models::LqFeedforward controller;  ///< with its meta
  nlohmann::json summary;            ///< the design's figures, as both doors give them
  nlohmann::json spectrum;           ///< {"f","plant_db","controlled_db","controller_db"}: magnitudes to plot
  std::vector<std::string> warnings;  ///< sentences on what the user may want to change
};

/// Throws RequestError naming the field for a request out of range (the plant model is read by design_lq).
void check(const DesignLqRequest& request);

/// The request's fields with their values (the plant model by its name), as the API echoes its params.
nlohmann::json to_json(const DesignLqRequest& request);

/// The linear model `design lq` designs on, from a plant model file object (RequestError naming `field`).
models::LinearModel lq_plant_model(const nlohmann::json& file, const std::string& field);

/// Designs the controller.
DesignLqReport design_lq(const DesignLqRequest& request, Progress& progress);

}  // namespace panelbass::usecases

#pragma once
// A linear model as stored in a model file: transfer function, sample rate, scaling, provenance.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "models/preprocess/scaling.h"
#include "models/linear/state_space.h"
#include "models/linear/transfer_function.h"

namespace panelbass::models {

/// A linear dynamic model in scaled units, with everything needed to apply it to raw data.
struct LinearModel {
  TransferFunction tf;          ///< from scaled input to scaled output
  double fs = 0.0;              ///< sample rate it was identified at, Hz
  Scaling scaling;              ///< raw ↔ scaled units
  std::string method;           ///< fir, arx, oe, zhu, backx
  nlohmann::json meta = nlohmann::json::object();  ///< provenance: data, orders, J, …

  /// Free-run simulation on raw input `u`, in raw output units. With `init_samples` > 0 the first
  /// `init_samples` measured outputs `y` (raw) set the initial state (benchmark protocol); otherwise the
  /// model starts at rest.
  Eigen::VectorXd simulate(const Eigen::VectorXd& u, const Eigen::VectorXd& y = {},
                           Eigen::Index init_samples = 0) const;

  /// One-step-ahead (series-parallel) prediction from measured past outputs, raw units: the thesis's
  /// "prediction" validation, ŷ(k) = −Σ a_i·y(k−i) + B(q)·u(k). The first max(na, nk + nb − 1)
  /// samples, whose regressors would reach before the record, are returned as measured (zero
  /// prediction error), exactly the samples an ARX fit leaves out.
  Eigen::VectorXd predict(const Eigen::VectorXd& u, const Eigen::VectorXd& y) const;
};

/// The model file: {"format":"panelbass.model/1","kind":"linear","fs","method","scaling",
/// "params":{"a","b","nk"},"meta"}; "method" is top level (optional on reading, "" when absent).
nlohmann::json linear_model_to_json(const LinearModel& m);

/// Reads a model file object and validates it: format and kind, shapes, finite coefficients, fs > 0,
/// and stability; ConfigError names the key ("model.params.a[3]: not finite", "model: unstable, pole
/// 1.02 at 150 Hz").
LinearModel linear_model_from_json(const nlohmann::json& j);

/// Writes `m` to `path` (pretty JSON); throws ConfigError naming the path if it cannot.
void save_linear_model(const std::filesystem::path& path, const LinearModel& m);

/// Reads a model file; errors start with the file name.
LinearModel load_linear_model(const std::filesystem::path& path);

}  // namespace panelbass::models

#pragma once
// Options every verb that reads a record shares: the file, its sample rate, and the columns.

#include <CLI/CLI.hpp>
#include <string>

#include "dsp/record.h"

namespace panelbass::cli {

/// Where a verb's data comes from.
struct DataOptions {
  double fs = 0.0;                  ///< --fs; required for CSV, checked against a WAV's own rate
  std::string input_col = "u";
  std::string output_col = "y";

  /// Adds --fs, --input-col and --output-col to `cmd`.
  void add_to(CLI::App* cmd);

  /// Reads the input and output columns of `path`; throws DataError (naming the file) if the sample rate
  /// is unknown or the file is bad; `min_samples` rows are required.
  dsp::Record read(const std::string& path, std::size_t min_samples = 10) const;

  /// Reads `path` for a model identified at `model_fs`: a CSV without --fs is taken at that rate, and
  /// any other rate is an error naming both.
  dsp::Record read_at_model_rate(const std::string& path, double model_fs) const;

  /// Reads the validation record `path` for estimation data sampled at `est_fs`; a different rate is an error
  /// naming the file.
  dsp::Record read_validation(const std::string& path, double est_fs) const;

  /// The input and output of an optional validation record.
  struct Validation {
    Eigen::VectorXd u, y;  ///< both empty without one
  };
  /// read_validation's input and output columns of `path`, or empty ones when `path` is empty (no --val).
  Validation read_optional_validation(const std::string& path, double est_fs) const;

  /// Reads --data `data` and the optional --val `val` into a use case's request of an estimation and a validation
  /// record (u_est, y_est, u_val, y_val, fs, data_name, val_name).
  template <typename Request>
  void read_into(Request& q, const std::string& data, const std::string& val) const {
    const dsp::Record est = read(data);
    const Validation v = read_optional_validation(val, est.fs);
    q.u_est = est.columns[0];
    q.y_est = est.columns[1];
    q.u_val = v.u;
    q.y_val = v.y;
    q.fs = est.fs;
    q.data_name = data;
    q.val_name = val;
  }
};

}  // namespace panelbass::cli

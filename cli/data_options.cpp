#include "cli/data_options.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "dsp/data_error.h"
#include "dsp/data_file.h"
#include "dsp/sample_rate.h"

namespace panelbass::cli {

void DataOptions::add_to(CLI::App* cmd) {
  cmd->add_option("--fs", fs, "Sample rate, Hz (required for CSV)")->check(CLI::PositiveNumber);
  cmd->add_option("--input-col", input_col, "Input column (CSV name, WAV channel name or index)")->capture_default_str();
  cmd->add_option("--output-col", output_col, "Output column")->capture_default_str();
}

dsp::Record DataOptions::read(const std::string& path, std::size_t min_samples) const {
  dsp::Record r = dsp::read_data_file(path, {input_col, output_col}, fs, min_samples);
  if (!(r.fs > 0.0)) throw dsp::DataError(path + ": sample rate unknown; give --fs HZ");
  return r;
}

dsp::Record DataOptions::read_at_model_rate(const std::string& path, double model_fs) const {
  DataOptions at_rate = *this;
  if (!(at_rate.fs > 0.0)) at_rate.fs = model_fs;  // a CSV recorded at the model's rate needs no --fs
  dsp::Record data = at_rate.read(path);
  if (!dsp::same_rate(data.fs, model_fs)) {
    throw dsp::DataError(path + ": sample rate " + std::to_string(data.fs) + " Hz differs from the model's " +
                         std::to_string(model_fs) + " Hz");
  }
  return data;
}

dsp::Record DataOptions::read_validation(const std::string& path, double est_fs) const {
  dsp::Record val = read(path);
  if (val.fs != est_fs) throw std::invalid_argument(path + ": sample rate differs from the estimation data");
  return val;
}

DataOptions::Validation DataOptions::read_optional_validation(const std::string& path, double est_fs) const {
  if (path.empty()) return {};
  const dsp::Record val = read_validation(path, est_fs);
  return {val.columns[0], val.columns[1]};
}

}  // namespace panelbass::cli

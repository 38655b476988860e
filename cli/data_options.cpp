#include "cli/data_options.h"

#include "dsp/data_error.h"
#include "dsp/data_file.h"

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

}  // namespace panelbass::cli

// libFuzzer target: CSV data files (dsp/csv_table.h read_csv, and dsp/data_file.h read_data_file, the
// front door the CLI and the jobs use). The input bytes are the file; a bad file must be a DataError
// naming the file and the place, never a crash, a hang or any other exception.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

#include "dsp/csv_table.h"
#include "dsp/data_error.h"
#include "fuzz/scratch_file.h"
#include "dsp/data_file.h"

namespace {

namespace fs = std::filesystem;

/// The input file, one per process.
const fs::path& input_path() {
  static const fs::path path = panelbass::fuzz::scratch_file("csv-fuzz", ".csv");
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using panelbass::dsp::DataError;
  const fs::path& path = input_path();
  panelbass::fuzz::write_input(path, data, size);
  try {
    const panelbass::dsp::Record record = panelbass::dsp::read_csv(path, {"u", "y"});
    (void)record;
  } catch (const DataError&) {
  }
  try {
    const panelbass::dsp::Record record = panelbass::dsp::read_data_file(path, {"y"}, 3000.0, 4);
    (void)record;
  } catch (const DataError&) {
  }
  return 0;
}

// libFuzzer target: WAV data files (dsp/wav_file.h read_wav through libsndfile, which reads from a path:
// the input bytes are written to a file in memory-backed /dev/shm). A bad file must be a DataError naming
// the file and the channel, never a crash, a hang or any other exception.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

#include "dsp/data_error.h"
#include "fuzz/scratch_file.h"
#include "dsp/wav_file.h"

namespace {

namespace fs = std::filesystem;

/// The input file, one per process.
const fs::path& input_path() {
  static const fs::path path = panelbass::fuzz::scratch_file("wav-fuzz", ".wav");
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using panelbass::dsp::DataError;
  const fs::path& path = input_path();
  panelbass::fuzz::write_input(path, data, size);
  // Channels by index, or (odd sizes) by the names stored in the comment tag: one read per input, since
  // each read_wav allocates its 8 MB chunk buffer, which costs ~50 ms of page faults under ASan.
  try {
    if (size % 2 == 0) {
      (void)panelbass::dsp::read_wav(path, {"0"});
    } else {
      (void)panelbass::dsp::read_wav(path, {"u", "y"}, 2);
    }
  } catch (const DataError&) {
  }
  return 0;
}

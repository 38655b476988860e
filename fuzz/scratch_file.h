#pragma once
// Temporary files of the fuzz targets: in $PANELBASS_FUZZ_TMP (scripts/fuzz.sh sets it and removes it
// afterwards, so nothing is left behind by a crash), else memory-backed /dev/shm, else the system temp folder.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

namespace panelbass::fuzz {

/// The folder temporary files go to.
inline std::filesystem::path scratch_base() {
  if (const char* tmp = std::getenv("PANELBASS_FUZZ_TMP"); tmp != nullptr && *tmp != '\0') return tmp;
  return std::filesystem::is_directory("/dev/shm") ? std::filesystem::path("/dev/shm")
                                                   : std::filesystem::temp_directory_path();
}

/// "panelbass-<stem>-<pid><extension>" in scratch_base(), removed at exit.
inline std::filesystem::path scratch_file(const std::string& stem, const std::string& extension) {
  static std::vector<std::filesystem::path> made;
  const std::filesystem::path file = scratch_base() / ("panelbass-" + stem + "-" + std::to_string(::getpid()) + extension);
  if (made.empty()) {
    std::atexit([] {
      std::error_code ignored;
      for (const auto& f : made) std::filesystem::remove(f, ignored);
    });
  }
  made.push_back(file);
  return file;
}

/// Writes the fuzz input byte for byte to `path` (aborts if it cannot: the harness is broken then).
inline void write_input(const std::filesystem::path& path, const std::uint8_t* data, std::size_t size) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, file) != size) std::abort();
  std::fclose(file);
}

}  // namespace panelbass::fuzz

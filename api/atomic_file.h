#pragma once
// Crash-safe file replacement: a reader (or a restart after kill -9) sees the old content or the new,
// never a torn mix.

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

namespace panelbass::api {

/// A file of the store could not be written or read; the message names the path and the reason.
class StoreError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Writes `text` to `path` atomically: a temporary file beside it, fsync, rename over `path`, fsync of
/// the folder. Throws StoreError (path + strerror, e.g. "No space left on device") when a step fails;
/// `path` then keeps its old content and the temporary file is removed.
void write_file_atomically(const std::filesystem::path& path, std::string_view text);

/// Reads a whole file; throws StoreError naming the path if it cannot.
std::string read_whole_file(const std::filesystem::path& path);

}  // namespace panelbass::api

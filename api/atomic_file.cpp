#include "api/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <string>

namespace panelbass::api {
namespace {

// Distinguishes the temporary files of concurrent writers in one process (the pid does across processes).
std::atomic<unsigned long> temp_counter{0};

[[noreturn]] void fail(const std::string& what, const std::filesystem::path& path, int error) {
  throw StoreError(what + " " + path.string() + ": " + std::strerror(error));
}

// Closes a descriptor once, keeping errno of the failure that matters.
class Descriptor {
 public:
  explicit Descriptor(int fd) : fd_(fd) {}
  ~Descriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  Descriptor(const Descriptor&) = delete;
  Descriptor& operator=(const Descriptor&) = delete;
  int get() const { return fd_; }
  /// Closes now; returns 0 or the errno of close().
  int close() {
    const int fd = fd_;
    fd_ = -1;
    return ::close(fd) == 0 ? 0 : errno;
  }

 private:
  int fd_;
};

// Writes all of `text` to `fd`; returns 0 or errno.
int write_all(int fd, std::string_view text) {
  const char* data = text.data();
  std::size_t left = text.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, data, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    data += n;
    left -= static_cast<std::size_t>(n);
  }
  return 0;
}

// Makes the rename durable. A file system that cannot sync a folder (EINVAL) gives no stronger promise.
void sync_folder(const std::filesystem::path& folder) {
  const Descriptor dir(::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (dir.get() < 0) fail("cannot open folder", folder, errno);
  if (::fsync(dir.get()) != 0 && errno != EINVAL) fail("cannot sync folder", folder, errno);
}

}  // namespace

void write_file_atomically(const std::filesystem::path& path, std::string_view text) {
  const std::filesystem::path folder = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  const std::filesystem::path temp =
      folder / ("." + path.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-" +
                std::to_string(temp_counter.fetch_add(1) + 1));

  Descriptor out(::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644));
  if (out.get() < 0) fail("cannot create", temp, errno);
  // From here on every failure removes the temporary file; `path` has not been touched yet.
  const auto fail_removing = [&temp](const std::string& what, const std::filesystem::path& named, int error) {
    ::unlink(temp.c_str());
    fail(what, named, error);
  };
  if (const int error = write_all(out.get(), text); error != 0) {
    out.close();
    fail_removing("cannot write", temp, error);
  }
  if (::fsync(out.get()) != 0) {
    const int error = errno;
    out.close();
    fail_removing("cannot sync", temp, error);
  }
  if (const int error = out.close(); error != 0) fail_removing("cannot close", temp, error);
  if (::rename(temp.c_str(), path.c_str()) != 0) fail_removing("cannot replace", path, errno);
  // The new content is in place; only its durability across a power cut is left to make sure of.
  sync_folder(folder);
}

std::string read_whole_file(const std::filesystem::path& path) {
  const Descriptor in(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (in.get() < 0) fail("cannot open", path, errno);
  std::string text;
  char buffer[65536];
  for (;;) {
    const ssize_t n = ::read(in.get(), buffer, sizeof buffer);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("cannot read", path, errno);
    }
    if (n == 0) break;
    text.append(buffer, static_cast<std::size_t>(n));
  }
  return text;
}

}  // namespace panelbass::api

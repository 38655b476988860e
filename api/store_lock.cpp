#include "api/store_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>
#include <system_error>

#include "api/atomic_file.h"

namespace panelbass::api {

StoreLock::StoreLock(const std::filesystem::path& store) {
  std::error_code error;
  std::filesystem::create_directories(store, error);
  if (error) throw StoreError("cannot create folder " + store.string() + ": " + error.message());
  const std::filesystem::path path = store / "serve.lock";
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw StoreError("cannot open " + path.string() + ": " + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int why = errno;
    char text[32] = {};
    const ssize_t n = ::pread(fd_, text, sizeof text - 1, 0);
    std::string holder = n > 0 ? std::string(text, static_cast<std::size_t>(n)) : "";
    holder = holder.substr(0, holder.find_first_not_of("0123456789"));
    ::close(fd_);
    fd_ = -1;
    if (why != EWOULDBLOCK) throw StoreError("cannot lock " + path.string() + ": " + std::strerror(why));
    throw StoreError("store " + store.string() + " is in use by another panelbass serve (pid " +
                     (holder.empty() ? std::string("unknown") : holder) +
                     "); stop that one, or give this one another --store");
  }
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
    // The lock holds without the pid; a second server then cannot name this one, which is all that is lost.
  }
}

StoreLock::~StoreLock() {
  if (fd_ >= 0) ::close(fd_);  // closing releases the flock
}

}  // namespace panelbass::api

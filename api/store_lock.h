#pragma once
// One server per store: an exclusive lock (flock) on <store>/serve.lock, held for the server's life, with the
// holder's process id written in it so that a second server can say who holds the store.

#include <filesystem>

namespace panelbass::api {

/// The store's exclusive lock; released when destroyed (or when the process ends, however it ends).
class StoreLock {
 public:
  /// Creates the folder if needed and takes the lock; throws StoreError naming the store and the process
  /// that holds it ("store panelbass-store is in use by another panelbass serve (pid 4242) …").
  explicit StoreLock(const std::filesystem::path& store);
  /// Releases the lock.
  ~StoreLock();
  StoreLock(const StoreLock&) = delete;
  StoreLock& operator=(const StoreLock&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace panelbass::api

#pragma once
// The record store: uploaded recordings (POST /api/records) under the store folder, each the file as it was
// sent beside a small JSON entry, both written atomically, read back at start-up.
//   root/records/<id>.wav|.csv   the uploaded file, byte for byte
//   root/records/<id>.json       {"format":"panelbass.stored-record/1","id","name","created","fs","samples",
//                                 "file":"wav"|"csv","input","output","current","bytes"}

#include <cstddef>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "api/record_upload.h"
#include "dsp/record.h"

namespace panelbass::api {

/// What the store keeps about an uploaded record.
struct StoredRecord {
  std::string id;       ///< "r" + 12 hex digits of a hash of the file and the channels chosen
  std::string name;     ///< given at upload ("" if none)
  std::string created;  ///< UTC time, ISO 8601
  double fs = 0.0;      ///< the record's rate, Hz (the engine's)
  std::size_t samples = 0;  ///< samples per channel
  std::string file;     ///< "wav" or "csv": the uploaded file's format
  std::string input;    ///< the drive's channel in the file
  std::string output;   ///< the response's channel
  std::string current;  ///< the current's channel ("" when none)
  std::size_t bytes = 0;  ///< the uploaded file's size
};

/// The summary of a stored record as JSON: every field of StoredRecord, "current" null when none.
nlohmann::json stored_record_to_json(const StoredRecord& r);

/// True for an id of the record store's shape ("r" + 12 hex digits), which no job id has ("j" + digits).
bool is_record_id(std::string_view id);

/// Thread-safe store of uploaded records; every change is on disk (atomically) before it returns.
class RecordStore {
 public:
  /// Warnings (a skipped file, with its path and why) go to `warn`.
  using Warn = std::function<void(const std::string&)>;
  /// Opens root/records (creating it) and reads back every entry; an entry without its file, a file without
  /// its entry (an upload cut short) and left-over temporary files are removed or skipped with a warning.
  /// Throws StoreError if the folder cannot be created or read.
  explicit RecordStore(std::filesystem::path root, Warn warn = {});

  /// Reads and checks `body` (read_uploaded_record; HttpError when it is bad), then stores the file and its
  /// entry. The same file with the same channels has the same id: stored again it is not duplicated
  /// (`created` false), and a non-empty new `name` renames it. Throws StoreError when the store cannot be
  /// written: nothing is stored then.
  StoredRecord put(std::string_view body, const RecordUpload& upload, const std::string& name, double engine_fs,
                   bool* created = nullptr);
  /// The entry of `id`, if stored.
  std::optional<StoredRecord> find(const std::string& id) const;
  /// Every entry, oldest first.
  std::vector<StoredRecord> list() const;
  /// The samples of `id`: columns "u", "y" and (with a current channel) "i", at the entry's fs. Throws
  /// std::invalid_argument if `id` is not stored, StoreError if its file can no longer be read.
  dsp::Record data(const std::string& id) const;
  /// The file of `id` as it was uploaded (a periodic CSV is read from it by its own columns). Throws
  /// std::invalid_argument if `id` is not stored.
  std::filesystem::path file(const std::string& id) const;
  /// Deletes `id`'s entry and file; false if it was not stored. Throws StoreError if they cannot be removed.
  bool remove(const std::string& id);

 private:
  // The two files of `id`; the caller holds mutex_ (or is the constructor).
  std::filesystem::path entry_path(const std::string& id) const;
  std::filesystem::path file_path(const std::string& id, const std::string& file) const;
  void write_entry(const StoredRecord& r) const;

  std::filesystem::path folder_;
  Warn warn_;
  mutable std::mutex mutex_;
  std::map<std::string, StoredRecord> records_;  // by id
  std::vector<std::string> order_;               // oldest first
};

}  // namespace panelbass::api

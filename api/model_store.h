#pragma once
// The model store: validated model files and finished job records under one folder, each file written
// atomically, read back at start-up (a corrupt or foreign file is skipped with a warning).
//   root/models/<id>.json  {"format":"panelbass.stored-model/1","id","name","created","source","model":{…}}
//   root/jobs/<id>.json    {"format":"panelbass.job/1", …the job record…}

#include <filesystem>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "api/atomic_file.h"

namespace panelbass::api {

/// True for an id the store accepts in a path: ^[A-Za-z0-9_-]{1,64}$ (no dots, no slashes).
bool is_valid_id(std::string_view id);

/// The store id of a model file object: "m" + 12 lower-case hex digits of engine::model_id(model).
std::string model_store_id(const nlohmann::json& model);
/// The store id of the model whose engine::model_id (a stage's id in the metrics) is `model_hash`.
std::string model_store_id(std::uint64_t model_hash);

/// What the store keeps about a model besides the file object.
struct StoredModel {
  std::string id;       ///< model_store_id of the file object
  std::string kind;     ///< "linear", "narx", "lq_feedforward", "neural_feedback"
  double fs = 0.0;      ///< the model's rate, Hz
  std::string name;     ///< given at upload or by the job ("" if none)
  std::string created;  ///< UTC time, ISO 8601 ("2026-11-22T09:00:00Z")
  std::string source;   ///< "upload" or the id of the job that made it
};

/// The summary of a stored model as JSON: {"id","kind","fs","name","created","source"}.
nlohmann::json stored_model_to_json(const StoredModel& m);

/// Thread-safe store of models and job records; every change is on disk (atomically) before it returns.
class ModelStore {
 public:
  /// Warnings (a skipped file, with its path and why) go to `warn`.
  using Warn = std::function<void(const std::string&)>;
  /// Opens (creating the folders if needed) and reads back every stored model and job record. Files that
  /// do not parse, carry another format tag, an id that differs from their name, or a model that fails
  /// `validate` (see model_validation.h) are skipped with a warning; left-over temporary files are removed.
  /// Throws StoreError if the folder cannot be created or read.
  explicit ModelStore(std::filesystem::path root, Warn warn = {});

  /// Stores an already validated model (kind and fs from `info`); returns its entry. A model already
  /// stored (same id) is not stored twice: the existing entry comes back and `created` is false; a
  /// non-empty `name` different from its own renames it (the file rewritten). Throws StoreError if the
  /// file cannot be written (nothing is changed then).
  StoredModel put(const nlohmann::json& model, const std::string& kind, double fs, const std::string& name,
                  const std::string& source, bool* created = nullptr);
  /// The entry of `id`, if stored.
  std::optional<StoredModel> find(const std::string& id) const;
  /// The model file object of `id`, if stored.
  std::optional<nlohmann::json> model(const std::string& id) const;
  /// Every entry, oldest first.
  std::vector<StoredModel> list() const;
  /// Deletes `id`'s file; false if it was not stored. Throws StoreError if the file cannot be removed.
  bool remove(const std::string& id);

  /// Writes (atomically, replacing) the record of job `id`; the store does not keep it in memory.
  /// Throws StoreError.
  void put_job(const std::string& id, const nlohmann::json& record);
  /// The job records read at start-up, in submission order (until release_jobs()).
  std::vector<nlohmann::json> jobs() const;
  /// Forgets the records read at start-up (once the job queue holds them), so memory stays bounded.
  void release_jobs();
  /// The stored record of job `id`, read from its file (nullopt if there is none or it is unreadable).
  std::optional<nlohmann::json> job(const std::string& id) const;

  /// The folder.
  const std::filesystem::path& root() const { return root_; }

 private:
  // Writes models/<id>.json (atomically); the caller holds mutex_. Throws StoreError.
  void write_stored_model(const StoredModel& entry, const nlohmann::json& model);

  std::filesystem::path root_;
  Warn warn_;
  mutable std::mutex mutex_;
  std::map<std::string, StoredModel> models_;         // by id
  std::map<std::string, nlohmann::json> model_files_;  // by id
  std::map<std::string, nlohmann::json> jobs_;         // by id
  std::vector<std::string> order_;                    // model ids, oldest first
};

}  // namespace panelbass::api

#include "api/model_store.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <system_error>
#include <tuple>
#include <utility>

#include "api/job_queue.h"
#include "api/model_validation.h"
#include "api/utc_time.h"
#include "engine/chain_file.h"
#include "models/io/bounded_json.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

constexpr const char* kStoredModelFormat = "panelbass.stored-model/1";
constexpr const char* kJobFormat = "panelbass.job/1";

// A temporary file write_file_atomically() leaves behind when the process dies mid-write.
bool is_temporary(const std::string& name) { return name.starts_with(".") && name.find(".tmp-") != std::string::npos; }

// A string member of a stored object; std::invalid_argument naming it otherwise.
std::string string_field(const json& object, const char* key) {
  const auto it = object.find(key);
  if (it == object.end()) throw std::invalid_argument(std::string(key) + ": missing");
  if (!it->is_string()) throw std::invalid_argument(std::string(key) + ": expected a string, got " + it->type_name());
  return it->get<std::string>();
}

// The object of a stored file with the format tag `format` and an "id" equal to the file's name, or
// std::invalid_argument saying why not.
json read_stored(const std::filesystem::path& path, const char* format) {
  json object;
  try {
    object = models::parse_bounded_json(read_whole_file(path));
  } catch (const json::exception& e) {
    throw std::invalid_argument(std::string("not valid JSON (") + e.what() + ")");
  } catch (const models::JsonLimitError& e) {
    throw std::invalid_argument(std::string("not acceptable JSON (") + e.what() + ")");
  }
  if (!object.is_object()) throw std::invalid_argument(std::string("expected a JSON object, got ") + object.type_name());
  const std::string tag = string_field(object, "format");
  if (tag != format) throw std::invalid_argument("format \"" + tag + "\", expected \"" + format + "\"");
  const std::string id = string_field(object, "id");
  if (!is_valid_id(id)) throw std::invalid_argument("id \"" + id + "\" is not a valid id");
  if (id != path.stem().string()) throw std::invalid_argument("id \"" + id + "\" differs from the file name");
  return object;
}

// Natural order of job ids: "j2" before "j10".
bool job_id_less(const std::string& a, const std::string& b) {
  return a.size() != b.size() ? a.size() < b.size() : a < b;
}

// The paths of the folder's entries, by name (a stable order for the warnings).
std::vector<std::filesystem::path> entries_of(const std::filesystem::path& folder) {
  std::vector<std::filesystem::path> paths;
  std::error_code error;
  for (std::filesystem::directory_iterator it(folder, error), end; !error && it != end; it.increment(error)) {
    paths.push_back(it->path());
  }
  if (error) throw StoreError("cannot read folder " + folder.string() + ": " + error.message());
  std::sort(paths.begin(), paths.end());
  return paths;
}

}  // namespace

bool is_valid_id(std::string_view id) {
  if (id.empty() || id.size() > 64) return false;
  return std::all_of(id.begin(), id.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
}

std::string model_store_id(const json& model) { return model_store_id(engine::model_id(model)); }

std::string model_store_id(std::uint64_t model_hash) {
  char text[16];
  std::snprintf(text, sizeof text, "m%012llx", static_cast<unsigned long long>(model_hash & 0xffffffffffffULL));
  return text;
}

json stored_model_to_json(const StoredModel& m) {
  return {{"id", m.id}, {"kind", m.kind}, {"fs", m.fs}, {"name", m.name}, {"created", m.created}, {"source", m.source}};
}

ModelStore::ModelStore(std::filesystem::path root, Warn warn) : root_(std::move(root)), warn_(std::move(warn)) {
  if (!warn_) warn_ = [](const std::string& message) { std::cerr << "panelbass: warning: " << message << '\n'; };
  for (const char* folder : {"models", "jobs"}) {
    std::error_code error;
    std::filesystem::create_directories(root_ / folder, error);
    if (error) throw StoreError("cannot create folder " + (root_ / folder).string() + ": " + error.message());
  }

  // Returns true when `path` is a candidate record; otherwise removes it (a temporary file) or warns.
  const auto candidate = [this](const std::filesystem::path& path) {
    const std::string name = path.filename().string();
    if (is_temporary(name)) {
      std::error_code error;
      std::filesystem::remove(path, error);
      warn_(error ? "cannot remove left-over temporary file " + path.string() + ": " + error.message()
                  : "removed left-over temporary file " + path.string());
      return false;
    }
    std::error_code error;
    if (path.extension() != ".json" || !std::filesystem::is_regular_file(path, error)) {
      warn_("skipped " + path.string() + ": not a .json file");
      return false;
    }
    return true;
  };

  std::vector<StoredModel> loaded;
  for (const std::filesystem::path& path : entries_of(root_ / "models")) {
    if (!candidate(path)) continue;
    try {
      const json object = read_stored(path, kStoredModelFormat);
      StoredModel entry;
      entry.id = string_field(object, "id");
      entry.name = string_field(object, "name");
      entry.created = string_field(object, "created");
      entry.source = string_field(object, "source");
      const auto model = object.find("model");
      if (model == object.end()) throw std::invalid_argument("model: missing");
      // The id is the content hash: a model edited on disk would otherwise hide under its old id.
      if (model_store_id(*model) != entry.id) {
        throw std::invalid_argument("id \"" + entry.id + "\" does not match the model's content (" +
                                    model_store_id(*model) + ")");
      }
      const ValidatedModel valid = validate_model(*model);
      entry.kind = valid.kind;
      entry.fs = valid.fs;
      model_files_[entry.id] = *model;
      models_[entry.id] = entry;
      loaded.push_back(std::move(entry));
    } catch (const std::exception& e) {
      // ModelRejected, StoreError and the reasons of read_stored alike.
      warn_("skipped " + path.string() + ": " + e.what());
    }
  }
  std::sort(loaded.begin(), loaded.end(), [](const StoredModel& a, const StoredModel& b) {
    return std::tie(a.created, a.id) < std::tie(b.created, b.id);
  });
  for (const StoredModel& entry : loaded) order_.push_back(entry.id);

  for (const std::filesystem::path& path : entries_of(root_ / "jobs")) {
    if (!candidate(path)) continue;
    try {
      json record = read_stored(path, kJobFormat);
      record.erase("format");
      job_from_json(record);  // only to check it
      const std::string id = record["id"].get<std::string>();
      jobs_[id] = std::move(record);
    } catch (const std::exception& e) {
      warn_("skipped " + path.string() + ": " + e.what());
    }
  }
}

StoredModel ModelStore::put(const json& model, const std::string& kind, double fs, const std::string& name,
                            const std::string& source, bool* created) {
  const std::string id = model_store_id(model);
  const std::lock_guard lock(mutex_);
  if (const auto it = models_.find(id); it != models_.end()) {
    if (created != nullptr) *created = false;
    if (!name.empty() && name != it->second.name) {
      StoredModel renamed = it->second;
      renamed.name = name;
      write_stored_model(renamed, model_files_.at(id));  // before the entry changes: a failed write changes nothing
      it->second = renamed;
    }
    return it->second;
  }
  StoredModel entry{id, kind, fs, name, utc_now(), source};
  write_stored_model(entry, model);
  models_[id] = entry;
  model_files_[id] = model;
  order_.push_back(id);
  if (created != nullptr) *created = true;
  return entry;
}

void ModelStore::write_stored_model(const StoredModel& entry, const json& model) {
  const json file = {{"format", kStoredModelFormat}, {"id", entry.id},          {"name", entry.name},
                     {"created", entry.created},    {"source", entry.source}, {"model", model}};
  write_file_atomically(root_ / "models" / (entry.id + ".json"), file.dump(2));
}

std::optional<StoredModel> ModelStore::find(const std::string& id) const {
  const std::lock_guard lock(mutex_);
  const auto it = models_.find(id);
  if (it == models_.end()) return std::nullopt;
  return it->second;
}

std::optional<json> ModelStore::model(const std::string& id) const {
  const std::lock_guard lock(mutex_);
  const auto it = model_files_.find(id);
  if (it == model_files_.end()) return std::nullopt;
  return it->second;
}

std::vector<StoredModel> ModelStore::list() const {
  const std::lock_guard lock(mutex_);
  std::vector<StoredModel> out;
  out.reserve(order_.size());
  for (const std::string& id : order_) out.push_back(models_.at(id));
  return out;
}

bool ModelStore::remove(const std::string& id) {
  const std::lock_guard lock(mutex_);
  if (models_.find(id) == models_.end()) return false;
  const std::filesystem::path path = root_ / "models" / (id + ".json");
  std::error_code error;
  std::filesystem::remove(path, error);
  if (error && error != std::errc::no_such_file_or_directory) {
    throw StoreError("cannot remove " + path.string() + ": " + error.message());
  }
  models_.erase(id);
  model_files_.erase(id);
  order_.erase(std::find(order_.begin(), order_.end(), id));
  return true;
}

void ModelStore::put_job(const std::string& id, const json& record) {
  if (!is_valid_id(id)) throw StoreError("cannot store job \"" + id + "\": not a valid id");
  if (!record.is_object()) throw StoreError("cannot store job " + id + ": the record is not a JSON object");
  json stored = record;
  stored.erase("format");
  json file = stored;
  file["format"] = kJobFormat;
  file["id"] = id;
  stored["id"] = id;
  const std::lock_guard lock(mutex_);
  write_file_atomically(root_ / "jobs" / (id + ".json"), file.dump(2));
}

void ModelStore::release_jobs() {
  const std::lock_guard lock(mutex_);
  jobs_.clear();
}

std::optional<json> ModelStore::job(const std::string& id) const {
  if (!is_valid_id(id)) return std::nullopt;
  try {
    json record = read_stored(root_ / "jobs" / (id + ".json"), kJobFormat);
    record.erase("format");
    return record;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// The records as job_to_json() made them (without the store's format tag), in natural id order (j2 before
// j10), which is the order they were submitted in.
std::vector<json> ModelStore::jobs() const {
  const std::lock_guard lock(mutex_);
  std::vector<std::pair<std::string, json>> by_id(jobs_.begin(), jobs_.end());
  std::sort(by_id.begin(), by_id.end(), [](const auto& a, const auto& b) { return job_id_less(a.first, b.first); });
  std::vector<json> out;
  out.reserve(by_id.size());
  for (auto& [id, record] : by_id) out.push_back(std::move(record));
  return out;
}

}  // namespace panelbass::api

#include "api/record_store.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <stdexcept>
#include <system_error>
#include <tuple>
#include <utility>

#include "api/atomic_file.h"
#include "api/utc_time.h"
#include "dsp/data_error.h"
#include "dsp/data_file.h"
#include "models/io/bounded_json.h"

namespace panelbass::api {
namespace {

using nlohmann::json;

constexpr const char* kStoredRecordFormat = "panelbass.stored-record/1";

// "r" + the low 48 bits of a hash of the file's bytes and the choice of channels and rate.
std::string record_id(std::string_view body, const RecordUpload& upload) {
  const std::string choice = upload.input + '\n' + upload.output + '\n' + upload.current + '\n' + std::to_string(upload.fs);
  const std::uint64_t a = std::hash<std::string_view>{}(body);
  const std::uint64_t b = std::hash<std::string>{}(choice);
  const std::uint64_t h = (a ^ (b + 0x9e3779b97f4a7c15ULL + (a << 6) + (a >> 2))) & ((std::uint64_t{1} << 48) - 1);
  char text[16];
  std::snprintf(text, sizeof text, "r%012llx", static_cast<unsigned long long>(h));
  return text;
}

json entry_json(const StoredRecord& r) {
  json j = stored_record_to_json(r);
  j["format"] = kStoredRecordFormat;
  return j;
}

// The entry in a stored file, checked; std::invalid_argument saying why it is not one.
StoredRecord entry_from_file(const std::filesystem::path& path) {
  json j;
  try {
    j = models::parse_bounded_json(read_whole_file(path));
  } catch (const json::exception& e) {
    throw std::invalid_argument(std::string("not valid JSON (") + e.what() + ")");
  } catch (const models::JsonLimitError& e) {
    throw std::invalid_argument(std::string("not acceptable JSON (") + e.what() + ")");
  }
  if (!j.is_object() || j.value("format", "") != kStoredRecordFormat) {
    throw std::invalid_argument(std::string("not a \"") + kStoredRecordFormat + "\" entry");
  }
  try {
    StoredRecord r;
    r.id = j.at("id").get<std::string>();
    r.name = j.at("name").get<std::string>();
    r.created = j.at("created").get<std::string>();
    r.fs = j.at("fs").get<double>();
    r.samples = j.at("samples").get<std::size_t>();
    r.file = j.at("file").get<std::string>();
    r.input = j.at("input").get<std::string>();
    r.output = j.at("output").get<std::string>();
    r.current = j.at("current").is_null() ? "" : j.at("current").get<std::string>();
    r.bytes = j.at("bytes").get<std::size_t>();
    if (!is_record_id(r.id) || r.id != path.stem().string()) throw std::invalid_argument("id \"" + r.id + "\" is not its file's name");
    if (r.file != "wav" && r.file != "csv") throw std::invalid_argument("file \"" + r.file + "\" is neither wav nor csv");
    if (!(r.fs > 0.0)) throw std::invalid_argument("fs is not a rate");
    return r;
  } catch (const json::exception& e) {
    throw std::invalid_argument(std::string("a field is missing or of the wrong type (") + e.what() + ")");
  }
}

// Removes `path`, ignoring a file that is already gone; StoreError otherwise.
void remove_file(const std::filesystem::path& path) {
  std::error_code error;
  std::filesystem::remove(path, error);
  if (error && error != std::errc::no_such_file_or_directory) {
    throw StoreError("cannot remove " + path.string() + ": " + error.message());
  }
}

}  // namespace

json stored_record_to_json(const StoredRecord& r) {
  return {{"id", r.id},         {"name", r.name},     {"created", r.created},
          {"fs", r.fs},         {"samples", r.samples}, {"file", r.file},
          {"input", r.input},   {"output", r.output},
          {"current", r.current.empty() ? json(nullptr) : json(r.current)},
          {"bytes", r.bytes}};
}

bool is_record_id(std::string_view id) {
  return id.size() == 13 && id[0] == 'r' &&
         std::all_of(id.begin() + 1, id.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

RecordStore::RecordStore(std::filesystem::path root, Warn warn) : folder_(std::move(root) / "records"), warn_(std::move(warn)) {
  if (!warn_) warn_ = [](const std::string& message) { std::cerr << "panelbass: warning: " << message << '\n'; };
  std::error_code error;
  std::filesystem::create_directories(folder_, error);
  if (error) throw StoreError("cannot create folder " + folder_.string() + ": " + error.message());
  std::vector<std::filesystem::path> paths;
  for (std::filesystem::directory_iterator it(folder_, error), end; !error && it != end; it.increment(error)) {
    paths.push_back(it->path());
  }
  if (error) throw StoreError("cannot read folder " + folder_.string() + ": " + error.message());
  std::sort(paths.begin(), paths.end());
  std::vector<StoredRecord> loaded;
  std::vector<std::filesystem::path> data_files;
  for (const std::filesystem::path& path : paths) {
    const std::string name = path.filename().string();
    if (name.starts_with(".")) {  // an upload's scratch file or an atomic write's temporary, left by a crash
      std::error_code ignored;
      std::filesystem::remove(path, ignored);
      warn_("removed left-over temporary file " + path.string());
      continue;
    }
    if (path.extension() == ".wav" || path.extension() == ".csv") {
      data_files.push_back(path);
      continue;
    }
    try {
      if (path.extension() != ".json") throw std::invalid_argument("not a record's entry or file");
      StoredRecord r = entry_from_file(path);
      if (!std::filesystem::is_regular_file(file_path(r.id, r.file), error)) {
        throw std::invalid_argument("its file " + file_path(r.id, r.file).filename().string() + " is missing");
      }
      loaded.push_back(std::move(r));
    } catch (const std::exception& e) {
      warn_("skipped " + path.string() + ": " + e.what());
    }
  }
  std::sort(loaded.begin(), loaded.end(),
            [](const StoredRecord& a, const StoredRecord& b) { return std::tie(a.created, a.id) < std::tie(b.created, b.id); });
  for (StoredRecord& r : loaded) {
    order_.push_back(r.id);
    records_[r.id] = std::move(r);
  }
  // A file without an entry: an upload that stopped between its two writes.
  for (const std::filesystem::path& path : data_files) {
    const auto it = records_.find(path.stem().string());
    if (it != records_.end() && path.extension() == "." + it->second.file) continue;
    std::error_code ignored;
    std::filesystem::remove(path, ignored);
    warn_("removed " + path.string() + ": a record file without its entry (an upload cut short)");
  }
}

std::filesystem::path RecordStore::entry_path(const std::string& id) const { return folder_ / (id + ".json"); }

std::filesystem::path RecordStore::file_path(const std::string& id, const std::string& file) const {
  return folder_ / (id + "." + file);
}

void RecordStore::write_entry(const StoredRecord& r) const { write_file_atomically(entry_path(r.id), entry_json(r).dump(2)); }

StoredRecord RecordStore::put(std::string_view body, const RecordUpload& upload, const std::string& name,
                              double engine_fs, bool* created) {
  const dsp::Record record = read_uploaded_record(body, upload, engine_fs, folder_);
  StoredRecord entry;
  entry.id = record_id(body, upload);
  entry.name = name;
  entry.created = utc_now();
  entry.fs = record.fs;
  entry.samples = record.samples();
  entry.file = upload_format_name(upload_format(body, upload.content_type));
  entry.input = upload.input;
  entry.output = upload.output;
  entry.current = upload.current;
  entry.bytes = body.size();

  const std::lock_guard lock(mutex_);
  if (const auto it = records_.find(entry.id); it != records_.end()) {
    if (created != nullptr) *created = false;
    if (!name.empty() && name != it->second.name) {
      StoredRecord renamed = it->second;
      renamed.name = name;
      write_entry(renamed);  // before the entry changes: a failed write changes nothing
      it->second = renamed;
    }
    return it->second;
  }
  // The file first, then its entry: a crash between the two leaves a file without an entry, removed at start-up.
  const std::filesystem::path file = file_path(entry.id, entry.file);
  write_file_atomically(file, body);
  try {
    write_entry(entry);
  } catch (const StoreError&) {
    std::error_code ignored;
    std::filesystem::remove(file, ignored);
    throw;
  }
  records_[entry.id] = entry;
  order_.push_back(entry.id);
  if (created != nullptr) *created = true;
  return entry;
}

std::optional<StoredRecord> RecordStore::find(const std::string& id) const {
  const std::lock_guard lock(mutex_);
  const auto it = records_.find(id);
  if (it == records_.end()) return std::nullopt;
  return it->second;
}

std::vector<StoredRecord> RecordStore::list() const {
  const std::lock_guard lock(mutex_);
  std::vector<StoredRecord> out;
  out.reserve(order_.size());
  for (const std::string& id : order_) out.push_back(records_.at(id));
  return out;
}

dsp::Record RecordStore::data(const std::string& id) const {
  const std::optional<StoredRecord> entry = find(id);
  if (!entry) throw std::invalid_argument("no uploaded record \"" + id + "\"");
  std::vector<std::string> channels = {entry->input, entry->output};
  if (!entry->current.empty()) channels.push_back(entry->current);
  // The file was checked at upload; a CSV at the fs given then, a WAV at its own (the engine's).
  dsp::Record read;
  try {
    read = dsp::read_data_file(file_path(entry->id, entry->file), channels, entry->file == "csv" ? entry->fs : 0.0,
                               kMinRecordSamples);
  } catch (const dsp::DataError& e) {
    throw StoreError(std::string("record ") + id + " can no longer be read: " + e.what());
  }
  dsp::Record out;
  out.fs = entry->fs;
  out.add("u", read.columns[0]);
  out.add("y", read.columns[1]);
  if (!entry->current.empty()) out.add("i", read.columns[2]);
  return out;
}

std::filesystem::path RecordStore::file(const std::string& id) const {
  const std::optional<StoredRecord> entry = find(id);
  if (!entry) throw std::invalid_argument("no uploaded record \"" + id + "\"");
  return file_path(entry->id, entry->file);
}

bool RecordStore::remove(const std::string& id) {
  const std::lock_guard lock(mutex_);
  const auto it = records_.find(id);
  if (it == records_.end()) return false;
  // The entry first: a crash after it leaves a file without an entry, which start-up removes.
  remove_file(entry_path(id));
  remove_file(file_path(id, it->second.file));
  records_.erase(it);
  order_.erase(std::find(order_.begin(), order_.end(), id));
  return true;
}

}  // namespace panelbass::api

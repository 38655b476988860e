#include "dsp/data_file.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <system_error>

#include <unistd.h>

#include "dsp/csv_table.h"
#include "dsp/data_error.h"
#include "dsp/wav_file.h"

namespace panelbass::dsp {
namespace {

enum class DataFileType { csv, wav };

std::string number_text(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

DataFileType type_of(const std::filesystem::path& path) {
  std::string extension = path.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (extension == ".csv") return DataFileType::csv;
  if (extension == ".wav") return DataFileType::wav;
  throw DataError(path.string() + ": unknown data file type (use .csv or .wav)");
}

}  // namespace

Record read_data_file(const std::filesystem::path& path, const std::vector<std::string>& columns, double fs,
                      std::size_t min_samples) {
  const DataFileType type = type_of(path);
  if (!(fs >= 0.0) || !std::isfinite(fs)) {
    throw DataError(path.string() + ": sample rate " + number_text(fs) +
                    " Hz is not valid (give a rate > 0, or 0 when it is not known)");
  }
  if (type == DataFileType::csv) {
    Record record = read_csv(path, columns, min_samples);
    record.fs = fs;
    return record;
  }
  Record record = read_wav(path, columns, min_samples);
  if (fs > 0.0 && fs != record.fs) {
    throw DataError(path.string() + ": the file's sample rate is " + number_text(record.fs) + " Hz, but " +
                    number_text(fs) + " Hz was given");
  }
  return record;
}

void check_writable_data_file(const std::filesystem::path& path) {
  type_of(path);
  std::filesystem::path dir = path.parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) throw DataError(path.string() + ": cannot write: no directory " + dir.string());
  if (std::filesystem::is_directory(path, ec)) throw DataError(path.string() + ": cannot write: is a directory");
  if (::access(dir.c_str(), W_OK) != 0) throw DataError(path.string() + ": cannot write: directory not writable");
}

void write_data_file(const std::filesystem::path& path, const Record& record) {
  if (type_of(path) == DataFileType::csv) {
    write_csv(path, record);
  } else {
    write_wav(path, record, WavFormat::float32);
  }
}

}  // namespace panelbass::dsp

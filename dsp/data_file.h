#pragma once
// One entry point for data files of either kind, chosen by the file's extension.

#include <filesystem>
#include <string>
#include <vector>

#include "dsp/record.h"

namespace panelbass::dsp {

/// Reads the named columns (CSV) or channels (WAV, name or index) from `path` by its extension
/// (.csv or .wav, any case). `fs` > 0 sets the sample rate of a CSV file and must agree with a WAV
/// file's own rate; the returned record always has fs > 0 unless neither gives one (then fs = 0).
/// Throws DataError for an unknown extension, a rate mismatch, or any reader error.
Record read_data_file(const std::filesystem::path& path, const std::vector<std::string>& columns,
                      double fs = 0.0, std::size_t min_samples = 1);

/// Throws DataError unless `path` has a known extension and its directory exists and is writable: a
/// check to make before long work whose result goes there.
void check_writable_data_file(const std::filesystem::path& path);

/// Writes `record` as CSV or as float WAV by the extension of `path`; throws DataError otherwise.
void write_data_file(const std::filesystem::path& path, const Record& record);

}  // namespace panelbass::dsp

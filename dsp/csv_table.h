#pragma once
// CSV data files with a header row (the project's data-file contract).

#include <filesystem>
#include <string>
#include <vector>

#include "dsp/record.h"

namespace panelbass::dsp {

/// Reads the columns named in `columns` (in that order) from a CSV file whose first row is a header.
/// Every row must have as many fields as the header and every chosen value must be a finite number;
/// otherwise throws DataError naming the file, the line (1-based) and the column. At least
/// `min_samples` data rows are required. Nothing is skipped or padded. The record's fs is 0.
Record read_csv(const std::filesystem::path& path, const std::vector<std::string>& columns,
                std::size_t min_samples = 1);

/// Writes every column of `record` as CSV with a header row, at full double precision.
/// Throws DataError if the file cannot be written.
void write_csv(const std::filesystem::path& path, const Record& record);

}  // namespace panelbass::dsp

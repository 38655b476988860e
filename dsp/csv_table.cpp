#include "dsp/csv_table.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string_view>
#include <system_error>
#include <unordered_map>

#include "dsp/data_error.h"

namespace panelbass::dsp {
namespace {

using FilePtr = std::unique_ptr<std::FILE, int (*)(std::FILE*)>;

// Long garbage (a binary file, a pasted paragraph) must not flood a one-line message.
constexpr std::size_t kMaxShownChars = 40;

bool is_blank(char c) { return c == ' ' || c == '\t'; }

std::string_view trim(std::string_view text) {
  while (!text.empty() && is_blank(text.front())) text.remove_prefix(1);
  while (!text.empty() && is_blank(text.back())) text.remove_suffix(1);
  return text;
}

bool is_blank_line(std::string_view line) { return trim(line).empty(); }

/// `text` in double quotes for an error message, shortened if long.
std::string shown(std::string_view text) {
  if (text.size() <= kMaxShownChars) return "\"" + std::string(text) + "\"";
  return "\"" + std::string(text.substr(0, kMaxShownChars)) + "...\"";
}

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) out += (i ? ", " : "") + names[i];
  return out;
}

std::string read_whole_file(const std::filesystem::path& path, const std::string& label) {
  FilePtr file(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!file) throw DataError(label + ": cannot open: " + std::strerror(errno));
  std::string content;
  char buffer[1 << 16];
  std::size_t got = 0;
  while ((got = std::fread(buffer, 1, sizeof buffer, file.get())) > 0) content.append(buffer, got);
  // fopen succeeds on a directory; the read is what fails (EISDIR).
  if (std::ferror(file.get())) throw DataError(label + ": cannot read: " + std::strerror(errno));
  return content;
}

/// Splits one line into fields (RFC 4180 quoting, without line breaks inside quotes). Whitespace around
/// a field is dropped; inside quotes it is kept. Returns the problem, or an empty string when the line
/// is well formed. `fields` is reused across calls so that its strings keep their capacity.
std::string split_fields(std::string_view line, std::vector<std::string>& fields, std::size_t& count) {
  count = 0;
  std::size_t pos = 0;
  while (true) {
    if (fields.size() <= count) fields.emplace_back();
    std::string& field = fields[count++];
    while (pos < line.size() && is_blank(line[pos])) ++pos;
    if (pos < line.size() && line[pos] == '"') {
      field.clear();
      ++pos;
      while (true) {
        const std::size_t quote = line.find('"', pos);
        if (quote == std::string_view::npos) {
          return "field " + std::to_string(count) + ": unterminated quote";
        }
        field.append(line.substr(pos, quote - pos));
        pos = quote + 1;
        if (pos < line.size() && line[pos] == '"') {  // "" stands for one quote
          field.push_back('"');
          ++pos;
          continue;
        }
        break;
      }
      while (pos < line.size() && is_blank(line[pos])) ++pos;
      if (pos < line.size() && line[pos] != ',') {
        return "field " + std::to_string(count) + ": unexpected text after the closing quote";
      }
    } else {
      const std::size_t comma = std::min(line.find(',', pos), line.size());
      field.assign(trim(line.substr(pos, comma - pos)));
      pos = comma;
    }
    if (pos >= line.size()) return {};
    ++pos;  // past the comma; a trailing comma yields one more, empty, field
  }
}

/// Parses a whole field as a finite double; returns the problem, or an empty string on success.
std::string parse_number(std::string_view text, double& value) {
  text = trim(text);
  if (text.empty()) return "empty field";
  std::string_view digits = text;
  // from_chars rejects a leading '+', which people and tools do write ("+2").
  if (digits.front() == '+') {
    digits.remove_prefix(1);
    if (digits.empty() || digits.front() == '+' || digits.front() == '-') return "not a number: " + shown(text);
  }
  const char* end = digits.data() + digits.size();
  const auto [ptr, ec] = std::from_chars(digits.data(), end, value, std::chars_format::general);
  if (ec == std::errc::result_out_of_range) return "out of range: " + shown(text);
  if (ec != std::errc() || ptr != end) return "not a number: " + shown(text);
  if (!std::isfinite(value)) return "not finite: " + shown(text);
  return {};
}

/// Iterates the lines of a file's content, numbering them from 1 and dropping the "\r" of "\r\n".
class LineReader {
 public:
  explicit LineReader(std::string_view content) : rest_(content) {}

  bool next(std::string_view& line) {
    if (rest_.empty()) return false;  // a final "\n" ends the last line rather than starting one
    const std::size_t newline = rest_.find('\n');
    line = rest_.substr(0, newline);
    rest_.remove_prefix(newline == std::string_view::npos ? rest_.size() : newline + 1);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    ++number_;
    return true;
  }

  std::size_t number() const { return number_; }

 private:
  std::string_view rest_;
  std::size_t number_ = 0;
};

bool needs_quotes(const std::string& name) {
  return name.find_first_of(",\"") != std::string::npos || is_blank(name.front()) || is_blank(name.back());
}

std::string header_field(const std::string& name) {
  if (!needs_quotes(name)) return name;
  std::string out = "\"";
  for (char c : name) {
    if (c == '"') out.push_back('"');
    out.push_back(c);
  }
  return out + "\"";
}

}  // namespace

Record read_csv(const std::filesystem::path& path, const std::vector<std::string>& columns,
                std::size_t min_samples) {
  if (columns.empty()) throw std::invalid_argument("read_csv: no columns requested");
  const std::string label = path.string();
  const std::string content = read_whole_file(path, label);

  std::string_view text = content;
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);  // UTF-8 byte order mark (spreadsheets)
  if (text.find_first_not_of(" \t\r\n") == std::string_view::npos) throw DataError(label + ": empty file");

  LineReader lines(text);
  const auto fail = [&](const std::string& problem) -> DataError {
    return DataError(label + ":" + std::to_string(lines.number()) + ": " + problem);
  };
  const auto check_line = [&](std::string_view line) {
    // A NUL means UTF-16 text or a binary file; a lone CR means old Mac line endings.
    if (line.find('\0') != std::string_view::npos) {
      throw fail("contains a NUL byte (not a text file, or UTF-16 text; save it as UTF-8)");
    }
    if (line.find('\r') != std::string_view::npos) {
      throw fail("carriage return inside a line (only \\n and \\r\\n line endings are supported)");
    }
  };

  // Header: unique, non-empty names.
  std::string_view line;
  lines.next(line);
  check_line(line);
  if (is_blank_line(line)) throw fail("empty header line (the first line must name the columns)");
  std::vector<std::string> fields;
  std::size_t field_count = 0;
  if (std::string problem = split_fields(line, fields, field_count); !problem.empty()) throw fail(problem);
  std::vector<std::string> header(fields.begin(), fields.begin() + static_cast<std::ptrdiff_t>(field_count));
  std::unordered_map<std::string, std::size_t> index_of;
  for (std::size_t f = 0; f < header.size(); ++f) {
    if (header[f].empty()) throw fail("column " + std::to_string(f + 1) + " has an empty name");
    const auto [where, inserted] = index_of.emplace(header[f], f);
    if (!inserted) {
      throw fail("duplicate column name \"" + header[f] + "\" (columns " + std::to_string(where->second + 1) +
                 " and " + std::to_string(f + 1) + ")");
    }
  }

  std::vector<std::size_t> chosen;
  for (const std::string& name : columns) {
    const auto where = index_of.find(name);
    if (where == index_of.end()) {
      std::string message = label + ": no column \"" + name + "\" (columns: " + join(header) + ")";
      if (header.size() == 1 && header.front().find_first_of(";\t") != std::string::npos) {
        message += "; the file seems to use ';' or tabs between fields, but only ',' is supported";
      }
      throw DataError(message);
    }
    chosen.push_back(where->second);
  }

  // Data rows. A blank line is allowed only if nothing but blank lines follows it.
  std::vector<std::vector<double>> values(chosen.size());
  const auto expected_rows = static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
  for (auto& column : values) column.reserve(expected_rows);
  std::size_t first_blank_line = 0;
  while (lines.next(line)) {
    check_line(line);
    if (is_blank_line(line)) {
      if (first_blank_line == 0) first_blank_line = lines.number();
      continue;
    }
    if (first_blank_line != 0) {
      throw DataError(label + ":" + std::to_string(first_blank_line) +
                      ": empty line inside the data (data continues on line " + std::to_string(lines.number()) +
                      ")");
    }
    if (std::string problem = split_fields(line, fields, field_count); !problem.empty()) throw fail(problem);
    if (field_count != header.size()) {
      throw fail("expected " + std::to_string(header.size()) + " fields, found " + std::to_string(field_count));
    }
    for (std::size_t c = 0; c < chosen.size(); ++c) {
      double value = 0.0;
      if (std::string problem = parse_number(fields[chosen[c]], value); !problem.empty()) {
        throw fail("column \"" + columns[c] + "\": " + problem);
      }
      values[c].push_back(value);
    }
  }

  const std::size_t samples = values.front().size();
  if (samples < min_samples) {
    throw DataError(label + ": " + std::to_string(samples) + " samples, need at least " +
                    std::to_string(min_samples));
  }
  Record record;
  for (std::size_t c = 0; c < chosen.size(); ++c) {
    record.add(columns[c], Eigen::Map<const Eigen::VectorXd>(values[c].data(),
                                                              static_cast<Eigen::Index>(values[c].size())));
  }
  return record;
}

void write_csv(const std::filesystem::path& path, const Record& record) {
  const std::string label = path.string();
  if (record.names.size() != record.columns.size()) {
    throw std::invalid_argument("write_csv: the record has " + std::to_string(record.names.size()) + " names for " +
                                std::to_string(record.columns.size()) + " columns");
  }
  if (record.columns.empty()) throw DataError(label + ": nothing to write (the record has no columns)");
  const Eigen::Index samples = record.columns.front().size();

  // Refuse anything read_csv would reject, before touching the file.
  std::unordered_map<std::string, std::size_t> index_of;
  for (std::size_t c = 0; c < record.columns.size(); ++c) {
    const std::string& name = record.names[c];
    const std::string number = std::to_string(c + 1);
    if (record.columns[c].size() != samples) {
      throw std::invalid_argument("write_csv: column \"" + name + "\" has " +
                                  std::to_string(record.columns[c].size()) + " samples, column 1 has " +
                                  std::to_string(samples));
    }
    if (name.empty()) throw DataError(label + ": column " + number + " has an empty name");
    if (name.find_first_of("\r\n") != std::string::npos) {
      throw DataError(label + ": column " + number + ": the name contains a line break");
    }
    if (const auto [where, inserted] = index_of.emplace(name, c); !inserted) {
      throw DataError(label + ": duplicate column name \"" + name + "\" (columns " +
                      std::to_string(where->second + 1) + " and " + number + ")");
    }
    for (Eigen::Index k = 0; k < samples; ++k) {
      if (!std::isfinite(record.columns[c](k))) {
        throw DataError(label + ": column \"" + name + "\", sample " + std::to_string(k) + ": not finite (" +
                        (std::isnan(record.columns[c](k)) ? "nan" : "inf") + ")");
      }
    }
  }

  FilePtr file(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!file) throw DataError(label + ": cannot write: " + std::strerror(errno));
  std::string out;
  const auto flush = [&] {
    if (std::fwrite(out.data(), 1, out.size(), file.get()) != out.size()) {
      const std::string reason = std::strerror(errno);
      file.reset();
      std::error_code ignored;  // the partial file is useless; failing to remove it changes nothing
      std::filesystem::remove(path, ignored);
      throw DataError(label + ": cannot write: " + reason);
    }
    out.clear();
  };

  for (std::size_t c = 0; c < record.names.size(); ++c) out += (c ? "," : "") + header_field(record.names[c]);
  out += '\n';
  // Shortest representation that reads back to the same double: a round trip is bit-exact.
  char number[32];
  for (Eigen::Index k = 0; k < samples; ++k) {
    for (std::size_t c = 0; c < record.columns.size(); ++c) {
      if (c) out += ',';
      const auto result = std::to_chars(number, number + sizeof number, record.columns[c](k));
      out.append(number, result.ptr);
    }
    out += '\n';
    if (out.size() > (1u << 20)) flush();
  }
  flush();
  if (std::fclose(file.release()) != 0) {
    const std::string reason = std::strerror(errno);
    std::error_code ignored;
    std::filesystem::remove(path, ignored);
    throw DataError(label + ": cannot write: " + reason);
  }
}

}  // namespace panelbass::dsp

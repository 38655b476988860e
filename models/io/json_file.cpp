#include "models/io/json_file.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>

#include "models/io/bounded_json.h"
#include "models/io/config_error.h"

namespace panelbass::models {

nlohmann::json read_json_file(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw ConfigError(path.string() + ": is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path.string() + ": cannot open: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw ConfigError(path.string() + ": cannot read");
  // The limits the API puts on JSON from outside (nesting counted while parsing, a key given twice): a file
  // handed to the CLI is as much from outside as an upload.
  try {
    return parse_bounded_json(text.str());
  } catch (const nlohmann::json::parse_error& e) {
    throw ConfigError(path.string() + ": not valid JSON: " + e.what());
  } catch (const nlohmann::json::out_of_range& e) {
    throw ConfigError(path.string() + ": not valid JSON: " + e.what());
  } catch (const JsonLimitError& e) {
    throw ConfigError(path.string() + ": not acceptable JSON: " + e.what());
  }
}

void write_json_file(const std::filesystem::path& path, const nlohmann::json& value) {
  const std::filesystem::path temporary = path.string() + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw ConfigError(path.string() + ": cannot write: " + std::strerror(errno));
    out << value.dump(2) << '\n';
    out.flush();
    if (!out) throw ConfigError(path.string() + ": cannot write (disk full?)");
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::filesystem::remove(temporary, ec);
    throw ConfigError(path.string() + ": cannot write: " + ec.message());
  }
}

}  // namespace panelbass::models

#include "cli/usecase_door.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <stdexcept>

namespace panelbass::cli {

std::string flag_of(const std::string& field, const std::map<std::string, std::string>& flags) {
  if (const auto it = flags.find(field); it != flags.end()) return it->second;
  const std::string head = field.substr(0, field.find('.'));
  if (const auto it = flags.find(head); it != flags.end()) return it->second;
  std::string flag = "--" + head;
  std::replace(flag.begin(), flag.end(), '_', '-');
  return flag;
}

void throw_refusal(const usecases::RequestError& e, const RequestSpelling& spelling) {
  if (const auto file = spelling.files.find(e.field()); file != spelling.files.end()) {
    throw std::invalid_argument(file->second + ": " + e.problem());
  }
  throw CLI::ValidationError(flag_of(e.field(), spelling.flags), e.problem());
}

void print_warnings(const std::string& verb, const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) std::fprintf(stderr, "%s: %s\n", verb.c_str(), w.c_str());
}

}  // namespace panelbass::cli

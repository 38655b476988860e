#include "dsp/record.h"

#include <stdexcept>
#include <utility>

#include "dsp/data_error.h"

namespace panelbass::dsp {

const Eigen::VectorXd& Record::column(std::string_view name) const {
  for (std::size_t c = 0; c < names.size() && c < columns.size(); ++c) {
    if (names[c] == name) return columns[c];
  }
  std::string message = "no column \"" + std::string(name) + "\"";
  if (names.empty()) {
    message += " (the record has no columns)";
  } else {
    message += " (columns: ";
    for (std::size_t c = 0; c < names.size(); ++c) message += (c ? ", " : "") + names[c];
    message += ")";
  }
  throw DataError(message);
}

void Record::add(std::string name, Eigen::VectorXd values) {
  if (!columns.empty() && values.size() != columns.front().size()) {
    throw std::invalid_argument("Record::add: column \"" + name + "\" has " + std::to_string(values.size()) +
                                " samples, the record's columns have " +
                                std::to_string(columns.front().size()));
  }
  names.push_back(std::move(name));
  columns.push_back(std::move(values));
}

}  // namespace panelbass::dsp

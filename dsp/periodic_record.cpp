#include "dsp/periodic_record.h"

#include <cmath>
#include <set>
#include <string>
#include <utility>

#include "dsp/csv_table.h"
#include "dsp/data_error.h"
#include "dsp/record.h"

namespace panelbass::dsp {
namespace {

/// The mean over periods of the matrices `periods`.
Eigen::MatrixXd mean_over_periods(const std::vector<Eigen::MatrixXd>& periods) {
  Eigen::MatrixXd sum = periods.front();
  for (std::size_t q = 1; q < periods.size(); ++q) sum += periods[q];
  return sum / static_cast<double>(periods.size());
}

/// value as a whole number, or a DataError naming the file, line and column.
long whole_number_at(double value, const std::string& label, Eigen::Index row, const std::string& column) {
  if (!(std::abs(value) < 1e9) || value != std::floor(value)) {
    throw DataError(label + ":" + std::to_string(row + 2) + ": column \"" + column + "\": not a whole number: " +
                    std::to_string(value));
  }
  return static_cast<long>(value);
}

}  // namespace

Eigen::MatrixXd PeriodicRecord::mean_input(std::size_t r) const { return mean_over_periods(u.at(r)); }

Eigen::MatrixXd PeriodicRecord::mean_output(std::size_t r) const { return mean_over_periods(y.at(r)); }

PeriodicRecord read_periodic_csv(const std::filesystem::path& path, const PeriodicColumns& columns, double fs) {
  if (columns.inputs.empty() || columns.outputs.empty()) {
    throw std::invalid_argument("read_periodic_csv: at least one input and one output column are needed");
  }
  std::vector<std::string> names{columns.realization, columns.period};
  names.insert(names.end(), columns.inputs.begin(), columns.inputs.end());
  names.insert(names.end(), columns.outputs.begin(), columns.outputs.end());
  const Record table = read_csv(path, names, 1);
  const std::string label = path.string();
  const auto rows = static_cast<Eigen::Index>(table.samples());
  const auto m = static_cast<Eigen::Index>(columns.inputs.size());
  const auto p = static_cast<Eigen::Index>(columns.outputs.size());

  // Runs of rows with the same (realisation, period): one period each.
  struct Run {
    long realization, period;
    Eigen::Index first, length;
  };
  std::vector<Run> runs;
  std::set<std::pair<long, long>> seen_periods;
  std::set<long> seen_realizations;
  for (Eigen::Index k = 0; k < rows; ++k) {
    const long r = whole_number_at(table.columns[0](k), label, k, columns.realization);
    const long q = whole_number_at(table.columns[1](k), label, k, columns.period);
    if (runs.empty() || runs.back().realization != r || runs.back().period != q) {
      const bool new_realization = runs.empty() || runs.back().realization != r;
      const bool seen = !seen_periods.emplace(r, q).second || (new_realization && !seen_realizations.insert(r).second);
      if (seen) {
        throw DataError(label + ":" + std::to_string(k + 2) + ": realization " + std::to_string(r) + ", period " +
                        std::to_string(q) + " continues after other rows (the rows of a period, and the periods of a "
                        "realization, must be contiguous)");
      }
      runs.push_back({r, q, k, 0});
    }
    ++runs.back().length;
  }

  PeriodicRecord out;
  out.inputs = columns.inputs;
  out.outputs = columns.outputs;
  out.fs = fs;
  out.period = runs.front().length;
  for (const Run& run : runs) {
    if (run.length != out.period) {
      throw DataError(label + ":" + std::to_string(run.first + 2) + ": realization " + std::to_string(run.realization) +
                      ", period " + std::to_string(run.period) + " has " + std::to_string(run.length) +
                      " rows, the first period has " + std::to_string(out.period));
    }
    if (&run == runs.data() || (&run - 1)->realization != run.realization) {
      out.u.emplace_back();
      out.y.emplace_back();
    }
    Eigen::MatrixXd u(out.period, m), y(out.period, p);
    for (Eigen::Index i = 0; i < m; ++i) u.col(i) = table.columns[2 + i].segment(run.first, run.length);
    for (Eigen::Index i = 0; i < p; ++i) y.col(i) = table.columns[2 + m + i].segment(run.first, run.length);
    out.u.back().push_back(std::move(u));
    out.y.back().push_back(std::move(y));
  }
  for (std::size_t r = 0; r < out.u.size(); ++r) {
    if (out.u[r].size() != out.u.front().size()) {
      throw DataError(label + ": realization " + std::to_string(r + 1) + " (in file order) has " +
                      std::to_string(out.u[r].size()) + " periods, the first has " + std::to_string(out.u.front().size()));
    }
  }
  return out;
}

PeriodicRecord select_realizations(const PeriodicRecord& record, std::size_t first, std::size_t count) {
  if (first + count > record.realizations() || count == 0) {
    throw std::invalid_argument("select_realizations: realizations " + std::to_string(first + 1) + ".." +
                                std::to_string(first + count) + " of " + std::to_string(record.realizations()));
  }
  PeriodicRecord out = record;
  out.u.assign(record.u.begin() + static_cast<std::ptrdiff_t>(first),
               record.u.begin() + static_cast<std::ptrdiff_t>(first + count));
  out.y.assign(record.y.begin() + static_cast<std::ptrdiff_t>(first),
               record.y.begin() + static_cast<std::ptrdiff_t>(first + count));
  return out;
}

void write_periodic_csv(const std::filesystem::path& path, const PeriodicRecord& record) {
  Record table;
  const Eigen::Index rows = record.period * static_cast<Eigen::Index>(record.realizations() * record.periods());
  const auto m = static_cast<Eigen::Index>(record.inputs.size());
  const auto p = static_cast<Eigen::Index>(record.outputs.size());
  Eigen::MatrixXd all(rows, 3 + m + p);
  Eigen::Index k = 0;
  for (std::size_t r = 0; r < record.realizations(); ++r) {
    for (std::size_t q = 0; q < record.periods(); ++q) {
      for (Eigen::Index n = 0; n < record.period; ++n, ++k) {
        all(k, 0) = static_cast<double>(r + 1);
        all(k, 1) = static_cast<double>(q + 1);
        all(k, 2) = static_cast<double>(n);
        all.row(k).segment(3, m) = record.u[r][q].row(n);
        all.row(k).segment(3 + m, p) = record.y[r][q].row(n);
      }
    }
  }
  std::vector<std::string> names{"realization", "period", "n"};
  names.insert(names.end(), record.inputs.begin(), record.inputs.end());
  names.insert(names.end(), record.outputs.begin(), record.outputs.end());
  for (Eigen::Index c = 0; c < all.cols(); ++c) table.add(names[static_cast<std::size_t>(c)], all.col(c));
  write_csv(path, table);
}

}  // namespace panelbass::dsp

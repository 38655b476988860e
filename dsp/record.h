#pragma once
// A measured or simulated record: named, equally long columns of samples.

#include <Eigen/Core>
#include <string>
#include <string_view>
#include <vector>

namespace panelbass::dsp {

/// Named columns of equal length, with the sample rate when known (0 = not known).
struct Record {
  std::vector<std::string> names;         ///< one name per column
  std::vector<Eigen::VectorXd> columns;   ///< the samples, columns[c](k)
  double fs = 0.0;                        ///< sample rate in Hz, 0 when the file does not say

  /// Number of samples per column (0 for an empty record).
  std::size_t samples() const { return columns.empty() ? 0 : static_cast<std::size_t>(columns.front().size()); }

  /// The column called `name`; throws DataError naming the columns there are.
  const Eigen::VectorXd& column(std::string_view name) const;

  /// Appends a column; throws std::invalid_argument if its length differs from the others.
  void add(std::string name, Eigen::VectorXd values);
};

}  // namespace panelbass::dsp

#pragma once
// Periodic multi-input multi-output records: several phase realisations of a periodic excitation, each
// measured over whole periods in steady state, as one CSV with realisation and period columns (the fine
// steering mirror's layout: realization, period, n, u1..u3, y1..y3).

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

namespace panelbass::dsp {

/// The columns a periodic MIMO CSV is read by.
struct PeriodicColumns {
  std::vector<std::string> inputs{"u1", "u2", "u3"};   ///< input columns, in order
  std::vector<std::string> outputs{"y1", "y2", "y3"};  ///< output columns, in order
  std::string realization = "realization";            ///< realisation number, constant within a realisation
  std::string period = "period";                      ///< period number within a realisation
};

/// Realisations × periods of an m-input p-output periodic experiment, N samples per period.
struct PeriodicRecord {
  std::vector<std::string> inputs, outputs;             ///< the column names
  Eigen::Index period = 0;                              ///< N, samples per period
  double fs = 0.0;                                      ///< sample rate, Hz (0 when not given)
  std::vector<std::vector<Eigen::MatrixXd>> u;          ///< u[r][q]: N×m input of realisation r, period q
  std::vector<std::vector<Eigen::MatrixXd>> y;          ///< y[r][q]: N×p output of realisation r, period q

  /// Number of realisations.
  std::size_t realizations() const { return u.size(); }
  /// Periods per realisation.
  std::size_t periods() const { return u.empty() ? 0 : u.front().size(); }
  /// Realisation r's input averaged over its periods (N×m), what a steady-state fit works on.
  Eigen::MatrixXd mean_input(std::size_t r) const;
  /// Realisation r's output averaged over its periods (N×p): the noise falls by the number of periods.
  Eigen::MatrixXd mean_output(std::size_t r) const;
};

/// Reads a periodic MIMO CSV: rows grouped by realisation, then by period (each group one contiguous run
/// of rows), every period N rows long, every realisation the same number of periods. Throws DataError
/// naming the file, and the column or line, when a column is missing, a value is not a number, a
/// realisation or period number is not a whole number, the groups are interleaved or of unequal length.
PeriodicRecord read_periodic_csv(const std::filesystem::path& path, const PeriodicColumns& columns, double fs = 0.0);

/// The realisations `first`..`first + count − 1` of `record` (for a split into estimation and validation).
PeriodicRecord select_realizations(const PeriodicRecord& record, std::size_t first, std::size_t count);

/// Writes `record` as a periodic CSV (realization, period, n, inputs, outputs) at full precision.
void write_periodic_csv(const std::filesystem::path& path, const PeriodicRecord& record);

}  // namespace panelbass::dsp

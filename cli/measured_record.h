#pragma once
// A record a backend measured, written as the CSV or WAV (by its extension) the identify and design verbs read (measure, tune --record).

#include <Eigen/Core>
#include <string>

namespace panelbass::cli {

/// Writes a measured record as the identify and design verbs read it: u, y and, where recorded (as long as u), i (the
/// coil current), w (a control excitation's harmonic weights) and l (the drive as the converters delivered it), at `fs`.
void write_measured_record(const std::string& path, double fs, const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                           const Eigen::VectorXd& i, const Eigen::VectorXd& w, const Eigen::VectorXd& l);

}  // namespace panelbass::cli

#pragma once
// Levels in decibels, the one way every plot and report writes them: NaN where the level is not positive
// (a plot leaves the point out, JSON writes null), never −inf.

#include <Eigen/Core>

namespace panelbass::dsp {

/// 10·log10(p) of each power in `p`, NaN where it is not positive.
Eigen::VectorXd power_db(const Eigen::VectorXd& p);

/// 20·log10|h| of each entry of a response `h`, NaN where it is 0.
Eigen::VectorXd magnitude_db(const Eigen::VectorXcd& h);

}  // namespace panelbass::dsp

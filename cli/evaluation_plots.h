#pragma once
// Figures of a chain evaluation (`panelbass evaluate --plot DIR`): the response of each configuration
// over the band, and the harmonics each leaves at every probe sine.

#include <filesystem>

#include "cli/gnuplot.h"
#include "evaluation/chain_evaluation.h"
#include "evaluation/level_sweep.h"

namespace panelbass::cli {

/// |program → measured output| in dB for every configuration, the ripple band marked; returns the image.
std::filesystem::path plot_evaluation_response(const evaluation::ChainEvaluation& e, const evaluation::EvaluationOptions& o,
                                               const std::filesystem::path& dir, PlotFormat format);

/// Harmonics 2..n relative to the fundamental (dB) at each probe, one series per configuration; returns the image.
std::filesystem::path plot_evaluation_harmonics(const evaluation::ChainEvaluation& e, const std::filesystem::path& dir,
                                                PlotFormat format);

/// THD against the sensor's fundamental level (as Klippel plots it): the chain (solid) and the plant alone at
/// equal output level (dashed), one colour per probe frequency, log-log; returns the image.
std::filesystem::path plot_level_sweep(const evaluation::LevelSweep& sweep, const std::filesystem::path& dir,
                                       PlotFormat format);

}  // namespace panelbass::cli

#pragma once
// The `--bandpass LO,HI` option the control verbs share: parsed and checked when the command line is
// read (a bad value is a usage error, exit 2), and turned into the band-pass of fig. 7.8.

#include <CLI/CLI.hpp>
#include <string>
#include <utility>
#include <vector>

#include "dsp/biquad.h"
#include "usecases/band_pass.h"

namespace panelbass::cli {

/// "LO,HI" → the corners in Hz (0 ≤ LO < HI); std::invalid_argument saying what is expected otherwise.
std::pair<double, double> parse_bandpass(const std::string& text);

/// "LO,HI" of `band` (its corners, as --bandpass takes them).
std::string band_pass_text(const usecases::BandPass& band);

/// Adds `--bandpass LO,HI` to `cmd`, stored as text in `text` (its default shown) and checked by
/// parse_bandpass() while parsing.
CLI::Option* add_bandpass_option(CLI::App* cmd, std::string& text, const std::string& help);

/// The band-pass as second-order sections: a Butterworth high-pass at `lo` cascaded with a low-pass at
/// `hi`, each of `order`; LO = 0 leaves the low-pass alone (the thesis's "0–1200 Hz"). Throws
/// std::invalid_argument naming --bandpass when `hi` is not below fs/2.
std::vector<dsp::Biquad> band_pass_sections(double lo, double hi, int order, double fs);

/// band_pass_sections() of the corners in `text`.
std::vector<dsp::Biquad> band_pass_sections(const std::string& text, int order, double fs);

}  // namespace panelbass::cli

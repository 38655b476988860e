#include "cli/band_pass_option.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "dsp/butterworth.h"
#include "models/io/number_text.h"

namespace panelbass::cli {

std::pair<double, double> parse_bandpass(const std::string& text) {
  const auto comma = text.find(',');
  try {
    if (comma == std::string::npos) throw std::invalid_argument("no comma");
    std::size_t used_lo = 0, used_hi = 0;
    const double lo = std::stod(text.substr(0, comma), &used_lo);
    const double hi = std::stod(text.substr(comma + 1), &used_hi);
    if (used_lo != comma || used_hi != text.size() - comma - 1) throw std::invalid_argument("trailing text");
    if (!std::isfinite(lo) || !std::isfinite(hi) || lo < 0.0 || !(hi > lo)) throw std::invalid_argument("bad corners");
    return {lo, hi};
  } catch (const std::exception&) {
    throw std::invalid_argument("expects LO,HI in Hz with 0 <= LO < HI (LO = 0: low-pass only), got \"" + text + "\"");
  }
}

std::string band_pass_text(const usecases::BandPass& band) {
  return models::number_text(band.low_hz) + "," + models::number_text(band.high_hz);
}

CLI::Option* add_bandpass_option(CLI::App* cmd, std::string& text, const std::string& help) {
  return cmd->add_option("--bandpass", text, help)
      ->check(CLI::Validator(
          [](std::string& value) {
            try {
              parse_bandpass(value);
            } catch (const std::invalid_argument& e) {
              return std::string(e.what());
            }
            return std::string();
          },
          "LO,HI", "bandpass"))
      ->capture_default_str();
}

std::vector<dsp::Biquad> band_pass_sections(double lo, double hi, int order, double fs) {
  if (!(hi < fs / 2.0)) {
    char message[160];
    std::snprintf(message, sizeof message, "--bandpass: upper corner %.8g Hz is not below the model's Nyquist frequency %.8g Hz",
                  hi, fs / 2.0);
    throw std::invalid_argument(message);
  }
  return dsp::butterworth_band(order, lo, hi, fs);
}

std::vector<dsp::Biquad> band_pass_sections(const std::string& text, int order, double fs) {
  const auto [lo, hi] = parse_bandpass(text);
  return band_pass_sections(lo, hi, order, fs);
}

}  // namespace panelbass::cli

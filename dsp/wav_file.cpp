#include "dsp/wav_file.h"

#include <sndfile.h>

#include <algorithm>
#include <cfloat>
#include <charconv>
#include <climits>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string_view>
#include <system_error>

#include "dsp/data_error.h"

namespace panelbass::dsp {
namespace {

struct SndfileCloser {
  void operator()(SNDFILE* file) const { sf_close(file); }
};
using SndfilePtr = std::unique_ptr<SNDFILE, SndfileCloser>;

// The comment tag that carries channel names: "panelbass-channels: u,y,i,x".
constexpr std::string_view kNamesTag = "panelbass-channels:";

// Samples per read/write chunk (all channels together): bounded memory for any file size.
constexpr std::size_t kChunkSamples = std::size_t{1} << 20;

std::string number_text(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

std::string_view trim(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t')) text.remove_suffix(1);
  return text;
}

std::string join(const std::vector<std::string>& names, const char* separator) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) out += (i ? separator : "") + names[i];
  return out;
}

/// libsndfile's error text, made to fit in a one-line message.
std::string sndfile_error(SNDFILE* file) {
  std::string text = sf_strerror(file);
  std::replace(text.begin(), text.end(), '\n', ' ');
  while (!text.empty() && (text.back() == '.' || text.back() == ' ')) text.pop_back();
  return text;
}

/// libsndfile's name for a major format or a subtype ("AIFF (Apple/SGI)", "IMA ADPCM").
std::string format_name(int format) {
  SF_FORMAT_INFO info{};
  info.format = format;
  if (sf_command(nullptr, SFC_GET_FORMAT_INFO, &info, sizeof info) != 0 || info.name == nullptr) {
    return "format 0x" + [&] {
      char buffer[16];
      const auto result = std::to_chars(buffer, buffer + sizeof buffer, format, 16);
      return std::string(buffer, result.ptr);
    }();
  }
  return info.name;
}

bool is_wav(int format) {
  const int major = format & SF_FORMAT_TYPEMASK;
  return major == SF_FORMAT_WAV || major == SF_FORMAT_WAVEX || major == SF_FORMAT_RF64;
}

bool is_pcm_or_float(int format) {
  switch (format & SF_FORMAT_SUBMASK) {
    case SF_FORMAT_PCM_S8:
    case SF_FORMAT_PCM_U8:
    case SF_FORMAT_PCM_16:
    case SF_FORMAT_PCM_24:
    case SF_FORMAT_PCM_32:
    case SF_FORMAT_FLOAT:
    case SF_FORMAT_DOUBLE:
      return true;
    default:
      return false;
  }
}

/// Channel names from the comment tag, or why they cannot be used.
struct ChannelNames {
  std::vector<std::string> names;  ///< empty when the file has no names
  std::string problem;             ///< non-empty when the tag is there but unusable
};

ChannelNames channel_names(SNDFILE* file, int channels) {
  ChannelNames result;
  const char* comment = sf_get_string(file, SF_STR_COMMENT);
  if (comment == nullptr) return result;
  std::string_view text = trim(comment);
  if (text.substr(0, kNamesTag.size()) != kNamesTag) return result;
  text.remove_prefix(kNamesTag.size());
  text = text.substr(0, text.find_first_of("\r\n"));
  while (true) {
    const std::size_t comma = std::min(text.find(','), text.size());
    result.names.emplace_back(trim(text.substr(0, comma)));
    if (comma == text.size()) break;
    text.remove_prefix(comma + 1);
  }
  if (result.names.size() != static_cast<std::size_t>(channels)) {
    result.problem = "the channel-name tag lists " + std::to_string(result.names.size()) +
                     " names for " + std::to_string(channels) + " channels";
  }
  for (std::size_t i = 0; i < result.names.size() && result.problem.empty(); ++i) {
    if (std::count(result.names.begin(), result.names.end(), result.names[i]) > 1) {
      result.problem = "the channel-name tag lists \"" + result.names[i] + "\" twice";
    }
  }
  return result;
}

std::string channels_text(int channels) {
  return std::to_string(channels) + (channels == 1 ? " channel" : " channels");
}

/// The zero-based channel that `spec` (an index or a name) designates.
int resolve_channel(const std::string& label, const std::string& spec, const ChannelNames& names, int channels) {
  const bool is_index = !spec.empty() && std::all_of(spec.begin(), spec.end(), [](char c) { return c >= '0' && c <= '9'; });
  if (is_index) {
    unsigned long index = 0;
    const auto [ptr, ec] = std::from_chars(spec.data(), spec.data() + spec.size(), index);
    if (ec != std::errc() || ptr != spec.data() + spec.size() || index >= static_cast<unsigned long>(channels)) {
      throw DataError(label + ": channel " + spec + " does not exist (file has " + channels_text(channels) + ")");
    }
    return static_cast<int>(index);
  }
  if (!names.problem.empty()) throw DataError(label + ": no channel \"" + spec + "\": " + names.problem);
  if (names.names.empty()) {
    throw DataError(label + ": no channel \"" + spec + "\" (the file has no channel names; use an index 0.." +
                    std::to_string(channels - 1) + ")");
  }
  const auto where = std::find(names.names.begin(), names.names.end(), spec);
  if (where == names.names.end()) {
    throw DataError(label + ": no channel \"" + spec + "\" (channels: " + join(names.names, ", ") + ")");
  }
  return static_cast<int>(where - names.names.begin());
}

const char* format_text(WavFormat format) {
  switch (format) {
    case WavFormat::pcm16: return "pcm16";
    case WavFormat::pcm24: return "pcm24";
    case WavFormat::float32: return "float32";
  }
  return "?";
}

/// Rejects, before anything is written, a record that write_wav cannot store faithfully.
void check_writable(const std::string& label, const Record& record, WavFormat format) {
  if (record.names.size() != record.columns.size()) {
    throw std::invalid_argument("write_wav: the record has " + std::to_string(record.names.size()) +
                                " names for " + std::to_string(record.columns.size()) + " columns");
  }
  if (record.columns.empty()) throw DataError(label + ": nothing to write (the record has no columns)");
  if (!(record.fs > 0.0) || !std::isfinite(record.fs)) {
    throw DataError(label + ": sample rate must be > 0 to write a WAV file (record.fs = " + number_text(record.fs) + ")");
  }
  if (record.fs != std::floor(record.fs) || record.fs > INT_MAX) {
    throw DataError(label + ": sample rate " + number_text(record.fs) +
                    " Hz cannot be stored in a WAV file (it must be a whole number of Hz)");
  }
  const Eigen::Index samples = record.columns.front().size();
  for (std::size_t c = 0; c < record.columns.size(); ++c) {
    const std::string& name = record.names[c];
    const Eigen::VectorXd& column = record.columns[c];
    if (column.size() != samples) {
      throw std::invalid_argument("write_wav: column \"" + name + "\" has " + std::to_string(column.size()) +
                                  " samples, column 1 has " + std::to_string(samples));
    }
    // The names travel as one comma-separated tag and are trimmed when read back.
    if (name.empty() || name.find_first_of(",\r\n") != std::string::npos || trim(name).size() != name.size()) {
      throw DataError(label + ": column " + std::to_string(c + 1) + " name \"" + name +
                      "\" cannot be stored as a channel name (it must be non-empty, without commas, line breaks "
                      "or surrounding spaces)");
    }
    if (std::count(record.names.begin(), record.names.end(), name) > 1) {
      throw DataError(label + ": duplicate column name \"" + name + "\"");
    }
    for (Eigen::Index k = 0; k < samples; ++k) {
      const double value = column(k);
      const auto where = [&] { return label + ": column \"" + name + "\", sample " + std::to_string(k) + ": "; };
      if (!std::isfinite(value)) throw DataError(where() + "not finite (" + (std::isnan(value) ? "nan" : "inf") + ")");
      if (format == WavFormat::float32 && std::abs(value) > FLT_MAX) {
        throw DataError(where() + number_text(value) + " is too large for float32");
      }
      if (format != WavFormat::float32 && std::abs(value) > 1.0) {
        throw DataError(where() + number_text(value) + " is outside [-1, 1], which " + format_text(format) +
                        " cannot hold (scale the signal; it is never clipped)");
      }
    }
  }
}

/// v in [-1, 1] as a signed integer of `bits` bits: round(v · 2^(bits-1)), with +1 mapped to the
/// largest code. This is the inverse of the 1/2^(bits-1) scaling libsndfile applies on reading; its
/// own normalised double writer scales by 2^(bits-1) - 1 instead, which would not round-trip.
long quantize(double value, int bits) {
  const double full_scale = std::ldexp(1.0, bits - 1);
  const long largest = static_cast<long>(full_scale) - 1;
  return std::clamp(std::lrint(value * full_scale), -largest - 1, largest);
}

}  // namespace

Record read_wav(const std::filesystem::path& path, const std::vector<std::string>& channels,
                std::size_t min_samples) {
  if (channels.empty()) throw std::invalid_argument("read_wav: no channels requested");
  const std::string label = path.string();

  std::error_code ignored;
  if (std::filesystem::is_directory(path, ignored)) throw DataError(label + ": cannot open: Is a directory");
  SF_INFO info{};
  SndfilePtr file(sf_open(path.c_str(), SFM_READ, &info));
  if (!file) {
    const bool system_error = sf_error(nullptr) == SF_ERR_SYSTEM;
    throw DataError(label + (system_error ? ": cannot open: " : ": not a readable WAV file: ") +
                    sndfile_error(nullptr));
  }
  if (!is_wav(info.format)) {
    throw DataError(label + ": not a WAV file (it is " + format_name(info.format & SF_FORMAT_TYPEMASK) + ")");
  }
  if (!is_pcm_or_float(info.format)) {
    throw DataError(label + ": unsupported sample encoding " + format_name(info.format & SF_FORMAT_SUBMASK) +
                    " (PCM or float WAV is required)");
  }
  if (info.channels < 1) throw DataError(label + ": the file has no channels");
  sf_command(file.get(), SFC_SET_NORM_DOUBLE, nullptr, SF_TRUE);  // PCM as k / 2^(bits-1), in [-1, 1)

  const ChannelNames names = channel_names(file.get(), info.channels);
  std::vector<int> chosen;
  for (const std::string& spec : channels) chosen.push_back(resolve_channel(label, spec, names, info.channels));

  const auto width = static_cast<std::size_t>(info.channels);
  const std::size_t chunk_frames = std::max<std::size_t>(1, kChunkSamples / width);
  std::vector<double> interleaved(chunk_frames * width);
  std::vector<std::vector<double>> values(chosen.size());
  if (info.frames > 0 && info.frames < SF_COUNT_MAX) {
    for (auto& column : values) column.reserve(static_cast<std::size_t>(info.frames));
  }
  std::size_t frame = 0;
  sf_count_t got = 0;
  while ((got = sf_readf_double(file.get(), interleaved.data(), static_cast<sf_count_t>(chunk_frames))) > 0) {
    for (sf_count_t f = 0; f < got; ++f, ++frame) {
      const double* samples = interleaved.data() + static_cast<std::size_t>(f) * width;
      for (std::size_t c = 0; c < chosen.size(); ++c) {
        const double value = samples[chosen[c]];
        if (!std::isfinite(value)) {
          const std::string name =
              names.problem.empty() && !names.names.empty() ? " (\"" + names.names[chosen[c]] + "\")" : "";
          throw DataError(label + ": channel " + std::to_string(chosen[c]) + name + ", frame " +
                          std::to_string(frame) + ": not finite (" + (std::isnan(value) ? "nan" : "inf") + ")");
        }
        values[c].push_back(value);
      }
    }
  }
  if (sf_error(file.get()) != SF_ERR_NO_ERROR) {
    throw DataError(label + ": read error at frame " + std::to_string(frame) + ": " + sndfile_error(file.get()));
  }
  if (frame < min_samples) {
    throw DataError(label + ": " + std::to_string(frame) + " frames, need at least " + std::to_string(min_samples));
  }

  // The columns are named as the caller asked for them, so record.column(spec) finds each one.
  Record record;
  record.fs = info.samplerate;
  for (std::size_t c = 0; c < chosen.size(); ++c) {
    record.add(channels[c], Eigen::Map<const Eigen::VectorXd>(values[c].data(),
                                                               static_cast<Eigen::Index>(values[c].size())));
  }
  return record;
}

void write_wav(const std::filesystem::path& path, const Record& record, WavFormat format) {
  const std::string label = path.string();
  check_writable(label, record, format);

  SF_INFO info{};
  info.samplerate = static_cast<int>(record.fs);
  info.channels = static_cast<int>(record.columns.size());
  info.format = SF_FORMAT_WAV | (format == WavFormat::pcm16   ? SF_FORMAT_PCM_16
                                 : format == WavFormat::pcm24 ? SF_FORMAT_PCM_24
                                                              : SF_FORMAT_FLOAT);
  if (!sf_format_check(&info)) {
    throw DataError(label + ": libsndfile cannot write a " + format_text(format) + " WAV file with " +
                    channels_text(info.channels) + " at " + std::to_string(info.samplerate) + " Hz");
  }
  SndfilePtr file(sf_open(path.c_str(), SFM_WRITE, &info));
  if (!file) throw DataError(label + ": cannot write: " + sndfile_error(nullptr));
  const auto fail = [&](const std::string& what) {
    const std::string reason = sndfile_error(file.get());
    file.reset();
    std::error_code ignored;  // a partial file is useless; failing to remove it changes nothing
    std::filesystem::remove(path, ignored);
    throw DataError(label + ": " + what + ": " + reason);
  };
  // Strings go in before the audio so that libsndfile places them in the header's LIST chunk.
  const std::string tag = std::string(kNamesTag) + " " + join(record.names, ",");
  if (sf_set_string(file.get(), SF_STR_COMMENT, tag.c_str()) != 0) fail("cannot store the channel names");

  const auto width = static_cast<std::size_t>(info.channels);
  const std::size_t chunk_frames = std::max<std::size_t>(1, kChunkSamples / width);
  const auto samples = static_cast<std::size_t>(record.columns.front().size());
  std::vector<short> pcm16;
  std::vector<int> pcm24;
  std::vector<float> float32;
  for (std::size_t first = 0; first < samples; first += chunk_frames) {
    const std::size_t frames = std::min(chunk_frames, samples - first);
    sf_count_t written = 0;
    const auto interleave = [&](auto& buffer, auto convert) {
      buffer.resize(frames * width);
      for (std::size_t f = 0; f < frames; ++f) {
        for (std::size_t c = 0; c < width; ++c) {
          buffer[f * width + c] = convert(record.columns[c](static_cast<Eigen::Index>(first + f)));
        }
      }
    };
    switch (format) {
      case WavFormat::pcm16:
        interleave(pcm16, [](double v) { return static_cast<short>(quantize(v, 16)); });
        written = sf_writef_short(file.get(), pcm16.data(), static_cast<sf_count_t>(frames));
        break;
      case WavFormat::pcm24:
        // libsndfile's int is left-justified: a 24-bit code sits in the top 24 of 32 bits.
        interleave(pcm24, [](double v) { return static_cast<int>(quantize(v, 24) * 256); });
        written = sf_writef_int(file.get(), pcm24.data(), static_cast<sf_count_t>(frames));
        break;
      case WavFormat::float32:
        interleave(float32, [](double v) { return static_cast<float>(v); });
        written = sf_writef_float(file.get(), float32.data(), static_cast<sf_count_t>(frames));
        break;
    }
    if (written != static_cast<sf_count_t>(frames)) fail("cannot write");
  }
  if (sf_close(file.release()) != 0) {
    std::error_code ignored;
    std::filesystem::remove(path, ignored);
    throw DataError(label + ": cannot write: " + sndfile_error(nullptr));
  }
}

}  // namespace panelbass::dsp

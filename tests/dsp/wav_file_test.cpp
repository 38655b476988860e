// WAV data files: known sample values from hand-made files, files written by libsndfile itself,
// round trips at each written format, and every way a file or a record is rejected.

#include "dsp/wav_file.h"

#include <gtest/gtest.h>
#include <sndfile.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <type_traits>

#include "dsp/data_error.h"
#include "tests/dsp/data_error_message.h"
#include "tests/support/expect_error.h"
#include "tests/support/scratch_directory.h"

namespace panelbass::dsp {
namespace {

namespace fs = std::filesystem;

constexpr std::uint16_t kWavePcm = 1;
constexpr std::uint16_t kWaveFloat = 3;

/// A fresh directory for one test, removed afterwards.
class WavFileTest : public testing_support::ScratchDirectoryTest {
 protected:
  /// A canonical 44-byte-header WAV file built byte by byte, independent of libsndfile.
  /// `data` holds the interleaved little-endian samples.
  fs::path raw_wav(const std::string& name, std::uint16_t format_tag, int channels, int rate, int bits,
                   const std::string& data) const {
    std::string out;
    const auto le = [&](std::uint32_t value, int bytes) {
      for (int b = 0; b < bytes; ++b) out.push_back(static_cast<char>((value >> (8 * b)) & 0xFF));
    };
    const auto block = static_cast<std::uint32_t>(channels * bits / 8);
    out += "RIFF";
    le(static_cast<std::uint32_t>(36 + data.size()), 4);
    out += "WAVEfmt ";
    le(16, 4);
    le(format_tag, 2);
    le(static_cast<std::uint32_t>(channels), 2);
    le(static_cast<std::uint32_t>(rate), 4);
    le(static_cast<std::uint32_t>(rate) * block, 4);
    le(block, 2);
    le(static_cast<std::uint32_t>(bits), 2);
    out += "data";
    le(static_cast<std::uint32_t>(data.size()), 4);
    out += data;
    return file(name, out);
  }

  /// Two's-complement integer codes as little-endian `bits`-wide PCM samples.
  static std::string pcm_bytes(const std::vector<std::int32_t>& codes, int bits) {
    std::string out;
    for (std::int32_t code : codes) {
      for (int b = 0; b < bits / 8; ++b) out.push_back(static_cast<char>((static_cast<std::uint32_t>(code) >> (8 * b)) & 0xFF));
    }
    return out;
  }

  static std::string float_bytes(const std::vector<float>& values) {
    std::string out(values.size() * 4, '\0');
    std::memcpy(out.data(), values.data(), out.size());  // the test host is little-endian like WAV
    return out;
  }

  /// A file written by libsndfile directly (not through panelbass), with an optional comment tag.
  /// Samples go in as float, or as short to set exact PCM16 codes (libsndfile's own float-to-PCM
  /// scaling is by 32767, not 32768).
  template <class Sample>
  fs::path sndfile_wav(const std::string& name, int format, int channels, int rate,
                       const std::vector<Sample>& interleaved, const char* comment) const {
    const fs::path path = dir_ / name;
    SF_INFO info{};
    info.samplerate = rate;
    info.channels = channels;
    info.format = format;
    SNDFILE* file = sf_open(path.c_str(), SFM_WRITE, &info);
    EXPECT_NE(file, nullptr) << sf_strerror(nullptr);
    if (file == nullptr) return path;
    if (comment != nullptr) {
      EXPECT_EQ(sf_set_string(file, SF_STR_COMMENT, comment), 0);
    }
    const auto frames = static_cast<sf_count_t>(interleaved.size()) / channels;
    if constexpr (std::is_same_v<Sample, short>) {
      EXPECT_EQ(sf_writef_short(file, interleaved.data(), frames), frames);
    } else {
      EXPECT_EQ(sf_writef_float(file, interleaved.data(), frames), frames);
    }
    sf_close(file);
    return path;
  }

  static int format_of(const fs::path& path) {
    SF_INFO info{};
    SNDFILE* file = sf_open(path.c_str(), SFM_READ, &info);
    if (file == nullptr) return 0;
    sf_close(file);
    return info.format;
  }
};

using testing::data_error;

Record two_columns(const Eigen::VectorXd& u, const Eigen::VectorXd& y, double fs) {
  Record record;
  record.add("u", u);
  record.add("y", y);
  record.fs = fs;
  return record;
}

/// Test signal: the full-scale ends, zero, tiny values and uniform noise in [-1, 1].
Eigen::VectorXd full_range_signal(unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::VectorXd x(1000);
  x.head(6) << -1.0, 1.0, 0.0, 1e-9, -1e-9, 0.5;
  for (Eigen::Index k = 6; k < x.size(); ++k) x(k) = uniform(random);
  return x;
}

// ---------------------------------------------------------------------------------------------
// Reading known values

TEST_F(WavFileTest, ReadsPcm16AsCodeOver32768) {
  const std::vector<std::int32_t> codes = {16384, -32768, 32767, 1, -1, 0};
  const fs::path path = raw_wav("pcm16.wav", kWavePcm, 1, 8000, 16, pcm_bytes(codes, 16));
  const Record record = read_wav(path, {"0"});
  EXPECT_EQ(record.fs, 8000.0);
  ASSERT_EQ(record.samples(), codes.size());
  for (std::size_t k = 0; k < codes.size(); ++k) {
    EXPECT_EQ(record.columns[0](static_cast<Eigen::Index>(k)), codes[k] / 32768.0) << "code " << codes[k];
  }
}

TEST_F(WavFileTest, ReadsPcm24AsCodeOver2To23) {
  // 0x400000 = 2^22 is exactly one half; 0x123456 has every byte different so a byte-order slip shows.
  const std::vector<std::int32_t> codes = {0x400000, 0x123456, -1, -0x800000, 0x7FFFFF, -0x123456};
  const fs::path path = raw_wav("pcm24.wav", kWavePcm, 2, 96000, 24, pcm_bytes(codes, 24));
  const Record record = read_wav(path, {"0", "1"});
  EXPECT_EQ(record.fs, 96000.0);
  ASSERT_EQ(record.samples(), 3u);
  EXPECT_EQ(record.columns[0](0), 0.5);
  EXPECT_EQ(record.columns[1](0), 1193046.0 / 8388608.0);
  EXPECT_EQ(record.columns[0](1), -1.0 / 8388608.0);
  EXPECT_EQ(record.columns[1](1), -1.0);
  EXPECT_EQ(record.columns[0](2), 8388607.0 / 8388608.0);
  EXPECT_EQ(record.columns[1](2), -1193046.0 / 8388608.0);
}

TEST_F(WavFileTest, ReadsFloat32Unscaled) {
  const std::vector<float> values = {0.25f, -1.5f, 3.0e-8f, 1.0f};
  const fs::path path = raw_wav("float.wav", kWaveFloat, 1, 44100, 32, float_bytes(values));
  const Record record = read_wav(path, {"0"});
  ASSERT_EQ(record.samples(), values.size());
  for (std::size_t k = 0; k < values.size(); ++k) {
    EXPECT_EQ(record.columns[0](static_cast<Eigen::Index>(k)), static_cast<double>(values[k]));
  }
}

TEST_F(WavFileTest, ReadsLibsndfileStereoFileByIndexAndByName) {
  const std::vector<short> interleaved = {16384, -8192, 4096, 24576, -32768, 0};  // u, y per frame
  const fs::path path = sndfile_wav("stereo.wav", SF_FORMAT_WAV | SF_FORMAT_PCM_16, 2, 48000, interleaved,
                                    "panelbass-channels: u,y");
  const Record by_index = read_wav(path, {"1", "0"});
  const Record by_name = read_wav(path, {"y", "u"});
  EXPECT_EQ(by_index.names, (std::vector<std::string>{"1", "0"}));  // named as asked
  EXPECT_EQ(by_name.names, (std::vector<std::string>{"y", "u"}));
  EXPECT_EQ(by_name.fs, 48000.0);
  // code / 32768
  EXPECT_EQ(by_index.columns[0], Eigen::Vector3d(-0.25, 0.75, 0.0));
  EXPECT_EQ(by_index.columns[1], Eigen::Vector3d(0.5, 0.125, -1.0));
  EXPECT_EQ(by_name.columns[0], by_index.columns[0]);
  EXPECT_EQ(by_name.columns[1], by_index.columns[1]);
  // Mixing names and indices, and asking for one channel twice, are fine.
  const Record mixed = read_wav(path, {"u", "1", "0"});
  EXPECT_EQ(mixed.columns[0], mixed.columns[2]);
  EXPECT_EQ(mixed.column("1"), by_name.column("y"));
}

TEST_F(WavFileTest, ToleratesSpacesInTheChannelNameTag) {
  const fs::path path = sndfile_wav("spaced.wav", SF_FORMAT_WAV | SF_FORMAT_FLOAT, 2, 8000, std::vector<float>{0.5f, 0.25f},
                                    "  panelbass-channels:  u ,\ty  ");
  const Record record = read_wav(path, {"y", "u"});
  EXPECT_EQ(record.columns[0](0), 0.25);
  EXPECT_EQ(record.columns[1](0), 0.5);
}

TEST_F(WavFileTest, ReadsZeroFramesWhenAllowed) {
  const fs::path path = raw_wav("empty.wav", kWavePcm, 1, 8000, 16, "");
  EXPECT_EQ(read_wav(path, {"0"}, 0).samples(), 0u);
}

// ---------------------------------------------------------------------------------------------
// Round trips

TEST_F(WavFileTest, Pcm16RoundTripIsWithinOneCode) {
  const Eigen::VectorXd u = full_range_signal(1);
  const Eigen::VectorXd y = full_range_signal(2);
  const fs::path path = dir_ / "pcm16.wav";
  write_wav(path, two_columns(u, y, 44100), WavFormat::pcm16);
  EXPECT_EQ(format_of(path), SF_FORMAT_WAV | SF_FORMAT_PCM_16);
  const Record back = read_wav(path, {"u", "y"});
  EXPECT_EQ(back.fs, 44100.0);
  ASSERT_EQ(back.samples(), 1000u);
  EXPECT_LE((back.column("u") - u).cwiseAbs().maxCoeff(), 1.0 / 32768);
  EXPECT_LE((back.column("y") - y).cwiseAbs().maxCoeff(), 1.0 / 32768);
  EXPECT_EQ(back.column("u")(0), -1.0);  // -1 is a code; +1 becomes the largest code, one step below
  EXPECT_EQ(back.column("u")(1), 32767.0 / 32768);
}

TEST_F(WavFileTest, Pcm24RoundTripIsWithinOneCode) {
  const Eigen::VectorXd u = full_range_signal(3);
  const Eigen::VectorXd y = full_range_signal(4);
  const fs::path path = dir_ / "pcm24.wav";
  write_wav(path, two_columns(u, y, 96000), WavFormat::pcm24);
  EXPECT_EQ(format_of(path), SF_FORMAT_WAV | SF_FORMAT_PCM_24);
  const Record back = read_wav(path, {"u", "y"});
  EXPECT_EQ(back.fs, 96000.0);
  EXPECT_LE((back.column("u") - u).cwiseAbs().maxCoeff(), std::ldexp(1.0, -23));
  EXPECT_LE((back.column("y") - y).cwiseAbs().maxCoeff(), std::ldexp(1.0, -23));
  EXPECT_EQ(back.column("u")(5), 0.5);
}

TEST_F(WavFileTest, Float32RoundTripIsFloatRounding) {
  Eigen::VectorXd u = full_range_signal(5);
  u(7) = 12.5;  // float files are not limited to [-1, 1]
  u(8) = -3.0e20;
  const Eigen::VectorXd y = full_range_signal(6) * 0.001;
  const fs::path path = dir_ / "float.wav";
  write_wav(path, two_columns(u, y, 8000), WavFormat::float32);
  EXPECT_EQ(format_of(path), SF_FORMAT_WAV | SF_FORMAT_FLOAT);
  const Record back = read_wav(path, {"u", "y"});
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    EXPECT_EQ(back.column("u")(k), static_cast<double>(static_cast<float>(u(k))));
    EXPECT_LE(std::abs(back.column("u")(k) - u(k)), FLT_EPSILON * std::abs(u(k)));
    EXPECT_LE(std::abs(back.column("y")(k) - y(k)), FLT_EPSILON * std::abs(y(k)));
  }
}

// ---------------------------------------------------------------------------------------------
// Reading: errors

TEST_F(WavFileTest, MissingFileIsAnError) {
  const fs::path path = dir_ / "absent.wav";
  EXPECT_EQ(data_error([&] { read_wav(path, {"0"}); }),
            path.string() + ": cannot open: System error : No such file or directory");
}

TEST_F(WavFileTest, DirectoryIsAnError) {
  EXPECT_EQ(data_error([&] { read_wav(dir_, {"0"}); }), dir_.string() + ": cannot open: Is a directory");
}

TEST_F(WavFileTest, TextFileIsNotAWav) {
  const fs::path path = dir_ / "text.wav";
  std::ofstream(path) << "u,y\n1,2\n";
  // The expected reason is whatever libsndfile itself says about this file.
  SF_INFO info{};
  ASSERT_EQ(sf_open(path.c_str(), SFM_READ, &info), nullptr);
  std::string reason = sf_strerror(nullptr);
  ASSERT_FALSE(reason.empty());
  if (reason.back() == '.') reason.pop_back();
  EXPECT_EQ(data_error([&] { read_wav(path, {"0"}); }), path.string() + ": not a readable WAV file: " + reason);
}

TEST_F(WavFileTest, OtherAudioFormatIsNotAWav) {
  const fs::path path = sndfile_wav("really-aiff.wav", SF_FORMAT_AIFF | SF_FORMAT_PCM_16, 1, 8000, std::vector<float>{0.5f}, nullptr);
  EXPECT_EQ(data_error([&] { read_wav(path, {"0"}); }), path.string() + ": not a WAV file (it is AIFF (Apple/SGI))");
}

TEST_F(WavFileTest, CompressedEncodingIsAnError) {
  const fs::path path = sndfile_wav("ulaw.wav", SF_FORMAT_WAV | SF_FORMAT_ULAW, 1, 8000, std::vector<float>{0.5f}, nullptr);
  EXPECT_EQ(data_error([&] { read_wav(path, {"0"}); }),
            path.string() + ": unsupported sample encoding U-Law (PCM or float WAV is required)");
}

TEST_F(WavFileTest, ChannelIndexOutOfRangeIsAnError) {
  const fs::path path = raw_wav("x.wav", kWavePcm, 2, 8000, 16, pcm_bytes({1, 2}, 16));
  EXPECT_EQ(data_error([&] { read_wav(path, {"0", "3"}); }),
            path.string() + ": channel 3 does not exist (file has 2 channels)");
  EXPECT_EQ(data_error([&] { read_wav(path, {"2"}); }), path.string() + ": channel 2 does not exist (file has 2 channels)");
  EXPECT_EQ(data_error([&] { read_wav(path, {"99999999999999999999999"}); }),
            path.string() + ": channel 99999999999999999999999 does not exist (file has 2 channels)");
  const fs::path mono = raw_wav("mono.wav", kWavePcm, 1, 8000, 16, pcm_bytes({1}, 16));
  EXPECT_EQ(data_error([&] { read_wav(mono, {"1"}); }), mono.string() + ": channel 1 does not exist (file has 1 channel)");
}

TEST_F(WavFileTest, UnknownChannelNameListsTheNames) {
  const fs::path path = sndfile_wav("named.wav", SF_FORMAT_WAV | SF_FORMAT_FLOAT, 2, 8000, std::vector<float>{0.1f, 0.2f},
                                    "panelbass-channels: u,x");
  EXPECT_EQ(data_error([&] { read_wav(path, {"u", "y"}); }), path.string() + ": no channel \"y\" (channels: u, x)");
}

TEST_F(WavFileTest, ChannelNameInAFileWithoutNamesIsAnError) {
  const fs::path path = raw_wav("plain.wav", kWavePcm, 2, 8000, 16, pcm_bytes({1, 2}, 16));
  EXPECT_EQ(data_error([&] { read_wav(path, {"y"}); }),
            path.string() + ": no channel \"y\" (the file has no channel names; use an index 0..1)");
  const fs::path other = sndfile_wav("comment.wav", SF_FORMAT_WAV | SF_FORMAT_FLOAT, 2, 8000, std::vector<float>{0.1f, 0.2f},
                                     "recorded on Tuesday");  // a comment that is not a name tag
  EXPECT_EQ(data_error([&] { read_wav(other, {"y"}); }),
            other.string() + ": no channel \"y\" (the file has no channel names; use an index 0..1)");
}

TEST_F(WavFileTest, NameTagThatDoesNotFitTheChannelsIsAnError) {
  const fs::path path = sndfile_wav("odd.wav", SF_FORMAT_WAV | SF_FORMAT_FLOAT, 2, 8000, std::vector<float>{0.1f, 0.2f},
                                    "panelbass-channels: u,y,x");
  EXPECT_EQ(data_error([&] { read_wav(path, {"u"}); }),
            path.string() + ": no channel \"u\": the channel-name tag lists 3 names for 2 channels");
  EXPECT_EQ(read_wav(path, {"1"}).columns[0](0), static_cast<double>(0.2f));  // indices still work
  const fs::path twice = sndfile_wav("twice.wav", SF_FORMAT_WAV | SF_FORMAT_FLOAT, 2, 8000, std::vector<float>{0.1f, 0.2f},
                                     "panelbass-channels: u,u");
  EXPECT_EQ(data_error([&] { read_wav(twice, {"u"}); }),
            twice.string() + ": no channel \"u\": the channel-name tag lists \"u\" twice");
}

TEST_F(WavFileTest, NonFiniteFloatSampleNamesChannelAndFrame) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const fs::path untagged = raw_wav("nan.wav", kWaveFloat, 2, 8000, 32, float_bytes({0, 0, 0, 0, 0, nan}));
  EXPECT_EQ(data_error([&] { read_wav(untagged, {"0", "1"}); }), untagged.string() + ": channel 1, frame 2: not finite (nan)");
  EXPECT_EQ(read_wav(untagged, {"0"}).samples(), 3u);  // only the channels asked for are checked
  const fs::path tagged = sndfile_wav("inf.wav", SF_FORMAT_WAV | SF_FORMAT_FLOAT, 2, 8000, std::vector<float>{0, 0, -inf, 0},
                                      "panelbass-channels: u,y");
  EXPECT_EQ(data_error([&] { read_wav(tagged, {"u"}); }), tagged.string() + ": channel 0 (\"u\"), frame 1: not finite (inf)");
}

TEST_F(WavFileTest, TooFewFramesIsAnError) {
  const fs::path path = raw_wav("short.wav", kWavePcm, 1, 8000, 16, pcm_bytes({1, 2, 3}, 16));
  EXPECT_EQ(data_error([&] { read_wav(path, {"0"}, 10); }), path.string() + ": 3 frames, need at least 10");
  EXPECT_EQ(read_wav(path, {"0"}, 3).samples(), 3u);
  const fs::path empty = raw_wav("empty.wav", kWavePcm, 1, 8000, 16, "");
  EXPECT_EQ(data_error([&] { read_wav(empty, {"0"}); }), empty.string() + ": 0 frames, need at least 1");
}

// ---------------------------------------------------------------------------------------------
// Writing: errors

TEST_F(WavFileTest, PcmValueOutsideFullScaleIsAnErrorNotClipped) {
  Eigen::VectorXd y(3);
  y << 0.5, 1.5, 0.0;
  const fs::path path = dir_ / "loud.wav";
  EXPECT_EQ(data_error([&] { write_wav(path, two_columns(Eigen::Vector3d::Zero(), y, 8000), WavFormat::pcm16); }),
            path.string() + ": column \"y\", sample 1: 1.5 is outside [-1, 1], which pcm16 cannot hold "
                            "(scale the signal; it is never clipped)");
  EXPECT_FALSE(fs::exists(path));
  y(1) = -1.0000001;
  EXPECT_EQ(data_error([&] { write_wav(path, two_columns(Eigen::Vector3d::Zero(), y, 8000), WavFormat::pcm24); }),
            path.string() + ": column \"y\", sample 1: -1.0000001 is outside [-1, 1], which pcm24 cannot hold "
                            "(scale the signal; it is never clipped)");
  EXPECT_NO_THROW(write_wav(path, two_columns(Eigen::Vector3d::Zero(), y, 8000), WavFormat::float32));
}

TEST_F(WavFileTest, NonFiniteValueIsAnErrorInEveryFormat) {
  Eigen::VectorXd u = Eigen::VectorXd::Zero(4);
  u(3) = std::numeric_limits<double>::quiet_NaN();
  const fs::path path = dir_ / "nan.wav";
  for (WavFormat format : {WavFormat::pcm16, WavFormat::pcm24, WavFormat::float32}) {
    EXPECT_EQ(data_error([&] { write_wav(path, two_columns(u, Eigen::VectorXd::Zero(4), 8000), format); }),
              path.string() + ": column \"u\", sample 3: not finite (nan)");
  }
  u(3) = 1e39;  // finite as a double, infinite as a float
  EXPECT_EQ(data_error([&] { write_wav(path, two_columns(u, Eigen::VectorXd::Zero(4), 8000), WavFormat::float32); }),
            path.string() + ": column \"u\", sample 3: 1e+39 is too large for float32");
}

TEST_F(WavFileTest, SampleRateMustBeAPositiveWholeNumber) {
  const fs::path path = dir_ / "rate.wav";
  const Eigen::VectorXd x = Eigen::VectorXd::Zero(4);
  EXPECT_EQ(data_error([&] { write_wav(path, two_columns(x, x, 0), WavFormat::float32); }),
            path.string() + ": sample rate must be > 0 to write a WAV file (record.fs = 0)");
  EXPECT_EQ(data_error([&] { write_wav(path, two_columns(x, x, -8000), WavFormat::float32); }),
            path.string() + ": sample rate must be > 0 to write a WAV file (record.fs = -8000)");
  EXPECT_EQ(data_error([&] { write_wav(path, two_columns(x, x, 44100.5), WavFormat::float32); }),
            path.string() + ": sample rate 44100.5 Hz cannot be stored in a WAV file (it must be a whole number of Hz)");
  EXPECT_FALSE(fs::exists(path));
}

TEST_F(WavFileTest, NamesThatCannotBeStoredAreAnError) {
  const fs::path path = dir_ / "names.wav";
  Record record;
  record.fs = 8000;
  record.add("u", Eigen::Vector2d::Zero());
  record.add("a,b", Eigen::Vector2d::Zero());
  EXPECT_EQ(data_error([&] { write_wav(path, record, WavFormat::float32); }),
            path.string() + ": column 2 name \"a,b\" cannot be stored as a channel name (it must be non-empty, "
                            "without commas, line breaks or surrounding spaces)");
  record.names[1] = "u";
  EXPECT_EQ(data_error([&] { write_wav(path, record, WavFormat::float32); }),
            path.string() + ": duplicate column name \"u\"");
  EXPECT_EQ(data_error([&] { write_wav(path, Record{.names = {}, .columns = {}, .fs = 8000}, WavFormat::pcm16); }),
            path.string() + ": nothing to write (the record has no columns)");
}

TEST_F(WavFileTest, UnwritablePathIsAnError) {
  const fs::path path = dir_ / "no-such-dir" / "out.wav";
  const Eigen::VectorXd x = Eigen::VectorXd::Zero(4);
  EXPECT_EQ(data_error([&] { write_wav(path, two_columns(x, x, 8000), WavFormat::pcm16); }),
            path.string() + ": cannot write: System error : No such file or directory");
}

}  // namespace
}  // namespace panelbass::dsp

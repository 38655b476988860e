// read_data_file / write_data_file (dispatch by extension, sample-rate rules) and Record.

#include "dsp/data_file.h"

#include <gtest/gtest.h>
#include <sndfile.h>

#include <filesystem>
#include <limits>
#include <stdexcept>
#include <string>

#include "dsp/data_error.h"
#include "tests/dsp/data_error_message.h"
#include "dsp/record.h"
#include "dsp/wav_file.h"
#include "tests/support/expect_error.h"
#include "tests/support/scratch_directory.h"

namespace panelbass::dsp {
namespace {

namespace fs = std::filesystem;

/// A fresh directory for one test, removed afterwards.
class DataFileTest : public testing_support::ScratchDirectoryTest {};

using testing::data_error;

Record sample_record(double fs) {
  Record record;
  record.add("u", Eigen::Vector3d(0.5, -0.25, 0.1));
  record.add("y", Eigen::Vector3d(0.0, 1.0 / 3.0, -1.0));
  record.fs = fs;
  return record;
}

// ---------------------------------------------------------------------------------------------
// Dispatch and sample rate

TEST_F(DataFileTest, CsvTakesTheGivenSampleRate) {
  const fs::path path = file("run.csv", "u,y\n1,2\n3,4\n");
  const Record with_rate = read_data_file(path, {"y"}, 48000);
  EXPECT_EQ(with_rate.fs, 48000.0);
  EXPECT_EQ(with_rate.columns[0], Eigen::Vector2d(2, 4));
  EXPECT_EQ(read_data_file(path, {"u"}).fs, 0.0);  // neither the file nor the caller gives one
}

TEST_F(DataFileTest, WavKeepsItsOwnSampleRate) {
  const fs::path path = dir_ / "run.wav";
  write_wav(path, sample_record(44100), WavFormat::pcm16);
  EXPECT_EQ(read_data_file(path, {"u", "y"}).fs, 44100.0);
  EXPECT_EQ(read_data_file(path, {"u", "y"}, 44100).fs, 44100.0);
  EXPECT_EQ(read_data_file(path, {"1"}).columns[0](0), 0.0);
}

TEST_F(DataFileTest, WavRateDifferentFromTheGivenOneIsAnError) {
  const fs::path path = dir_ / "run.wav";
  write_wav(path, sample_record(48000), WavFormat::float32);
  EXPECT_EQ(data_error([&] { read_data_file(path, {"u"}, 44100); }),
            path.string() + ": the file's sample rate is 48000 Hz, but 44100 Hz was given");
}

TEST_F(DataFileTest, ExtensionIsCaseInsensitive) {
  const fs::path csv = file("RUN.CSV", "u\n1\n");
  EXPECT_EQ(read_data_file(csv, {"u"}, 8000).columns[0](0), 1.0);
  const fs::path wav = dir_ / "Run.Wav";
  write_data_file(wav, sample_record(8000));
  EXPECT_EQ(read_data_file(wav, {"y"}).columns[0](2), -1.0);
}

TEST_F(DataFileTest, UnknownExtensionIsAnError) {
  for (const std::string name : {"x.txt", "x", "x.csv.bak", "x.wave"}) {
    const fs::path path = file(name, "u\n1\n");
    EXPECT_EQ(data_error([&] { read_data_file(path, {"u"}); }),
              path.string() + ": unknown data file type (use .csv or .wav)");
  }
  const fs::path out = dir_ / "out.flac";
  EXPECT_EQ(data_error([&] { write_data_file(out, sample_record(8000)); }),
            out.string() + ": unknown data file type (use .csv or .wav)");
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(DataFileTest, InvalidGivenSampleRateIsAnError) {
  const fs::path path = file("run.csv", "u\n1\n");
  EXPECT_EQ(data_error([&] { read_data_file(path, {"u"}, -48000); }),
            path.string() + ": sample rate -48000 Hz is not valid (give a rate > 0, or 0 when it is not known)");
  EXPECT_EQ(data_error([&] { read_data_file(path, {"u"}, std::numeric_limits<double>::quiet_NaN()); }),
            path.string() + ": sample rate nan Hz is not valid (give a rate > 0, or 0 when it is not known)");
}

TEST_F(DataFileTest, ReaderErrorsPassThrough) {
  const fs::path csv = file("run.csv", "u,y\n1,2\n3\n");
  EXPECT_EQ(data_error([&] { read_data_file(csv, {"u"}, 8000); }), csv.string() + ":3: expected 2 fields, found 1");
  const fs::path wav = dir_ / "run.wav";
  write_data_file(wav, sample_record(8000));
  EXPECT_EQ(data_error([&] { read_data_file(wav, {"u"}, 0, 4); }), wav.string() + ": 3 frames, need at least 4");
}

// ---------------------------------------------------------------------------------------------
// Writing

TEST_F(DataFileTest, WritesCsvThatReadsBackExactly) {
  const fs::path path = dir_ / "out.csv";
  const Record record = sample_record(8000);
  write_data_file(path, record);
  EXPECT_EQ(text_of(path), "u,y\n0.5,0\n-0.25,0.3333333333333333\n0.1,-1\n");
  const Record back = read_data_file(path, {"u", "y"}, 8000);
  EXPECT_EQ(back.columns[0], record.columns[0]);
  EXPECT_EQ(back.columns[1], record.columns[1]);
  EXPECT_EQ(back.fs, 8000.0);
}

TEST_F(DataFileTest, WritesWavAsFloat32) {
  const fs::path path = dir_ / "out.wav";
  write_data_file(path, sample_record(22050));
  SF_INFO info{};
  SNDFILE* file = sf_open(path.c_str(), SFM_READ, &info);
  ASSERT_NE(file, nullptr) << sf_strerror(nullptr);
  sf_close(file);
  EXPECT_EQ(info.format, SF_FORMAT_WAV | SF_FORMAT_FLOAT);
  EXPECT_EQ(info.channels, 2);
  EXPECT_EQ(info.samplerate, 22050);
  const Record back = read_data_file(path, {"y", "u"});
  EXPECT_EQ(back.columns[0](1), static_cast<double>(1.0f / 3.0f));
  EXPECT_EQ(back.columns[1](2), static_cast<double>(0.1f));
}

TEST_F(DataFileTest, WritingWavNeedsASampleRate) {
  const fs::path path = dir_ / "out.wav";
  EXPECT_EQ(data_error([&] { write_data_file(path, sample_record(0)); }),
            path.string() + ": sample rate must be > 0 to write a WAV file (record.fs = 0)");
}

// ---------------------------------------------------------------------------------------------
// Record

TEST(RecordTest, FindsColumnsByName) {
  Record record;
  EXPECT_EQ(record.samples(), 0u);
  record.add("u", Eigen::Vector2d(1, 2));
  record.add("y", Eigen::Vector2d(3, 4));
  EXPECT_EQ(record.samples(), 2u);
  EXPECT_EQ(record.column("y"), Eigen::Vector2d(3, 4));
  EXPECT_EQ(record.column("u"), Eigen::Vector2d(1, 2));
}

TEST(RecordTest, MissingColumnListsTheNames) {
  Record record;
  EXPECT_EQ(data_error([&] { record.column("u"); }), "no column \"u\" (the record has no columns)");
  record.add("u", Eigen::Vector2d(1, 2));
  record.add("x", Eigen::Vector2d(3, 4));
  EXPECT_EQ(data_error([&] { record.column("y"); }), "no column \"y\" (columns: u, x)");
}

TEST(RecordTest, AddingAColumnOfAnotherLengthIsInvalid) {
  Record record;
  record.add("u", Eigen::Vector2d(1, 2));
  try {
    record.add("y", Eigen::Vector3d(1, 2, 3));
    ADD_FAILURE() << "no std::invalid_argument was thrown";
  } catch (const std::invalid_argument& error) {
    EXPECT_STREQ(error.what(), "Record::add: column \"y\" has 3 samples, the record's columns have 2");
  }
  EXPECT_EQ(record.columns.size(), 1u);  // unchanged
  EXPECT_EQ(record.names.size(), 1u);
}

}  // namespace
}  // namespace panelbass::dsp

// CSV data files: what is accepted, every way a file is rejected, and bit-exact round trips.

#include "dsp/csv_table.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cfloat>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <numbers>
#include <random>
#include <string>

#include "dsp/data_error.h"
#include "tests/dsp/data_error_message.h"
#include "tests/support/expect_error.h"
#include "tests/support/scratch_directory.h"

namespace panelbass::dsp {
namespace {

namespace fs = std::filesystem;

/// A fresh directory for one test, removed afterwards.
class CsvTableTest : public testing_support::ScratchDirectoryTest {};

using testing::data_error;

std::uint64_t bits(double value) { return std::bit_cast<std::uint64_t>(value); }

// ---------------------------------------------------------------------------------------------
// Reading

TEST_F(CsvTableTest, ReadsChosenColumnsInRequestedOrder) {
  const fs::path path = file("data.csv", "u,x,y\n1,10,100\n2,20,200\n3,30,300\n");
  const Record record = read_csv(path, {"y", "u"});
  ASSERT_EQ(record.names, (std::vector<std::string>{"y", "u"}));
  ASSERT_EQ(record.samples(), 3u);
  EXPECT_EQ(record.columns[0], Eigen::Vector3d(100, 200, 300));
  EXPECT_EQ(record.columns[1], Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(record.fs, 0.0);
}

TEST_F(CsvTableTest, AcceptsCommonNumberForms) {
  const fs::path path = file("data.csv", "v\n1e-3\n-0.5\n+2\n.5\n5.\n1E3\n-.25\n+1.5e+2\n4.9e-324\n  7  \n\"8\"\n");
  const Record record = read_csv(path, {"v"});
  const std::vector<double> expected = {0.001, -0.5, 2.0, 0.5, 5.0, 1000.0, -0.25, 150.0, 4.9e-324, 7.0, 8.0};
  ASSERT_EQ(record.samples(), expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k) {
    EXPECT_EQ(bits(record.columns[0](static_cast<Eigen::Index>(k))), bits(expected[k])) << "row " << k;
  }
}

TEST_F(CsvTableTest, ReadsCrlfLineEndings) {
  for (const std::string ending : {"\r\n", ""}) {  // with and without a final line ending
    const fs::path path = file("crlf.csv", "u,y\r\n1,2\r\n3,4" + ending);
    const Record record = read_csv(path, {"u", "y"});
    EXPECT_EQ(record.column("u"), Eigen::Vector2d(1, 3));
    EXPECT_EQ(record.column("y"), Eigen::Vector2d(2, 4));
  }
}

TEST_F(CsvTableTest, ReadsQuotedHeaderNamesAndSurroundingWhitespace) {
  const fs::path path = file("quoted.csv", " \"u\" ,\t\"y\",\"a,b\", \"say \"\"hi\"\"\" \n 1 , 2,3,4\n5,\t6 ,7,8\n");
  const Record record = read_csv(path, {"u", "y", "a,b", "say \"hi\""});
  EXPECT_EQ(record.columns[0], Eigen::Vector2d(1, 5));
  EXPECT_EQ(record.columns[1], Eigen::Vector2d(2, 6));
  EXPECT_EQ(record.columns[2], Eigen::Vector2d(3, 7));
  EXPECT_EQ(record.columns[3], Eigen::Vector2d(4, 8));
}

TEST_F(CsvTableTest, ReadsWithOrWithoutTrailingNewlineAndIgnoresTrailingEmptyLines) {
  for (const std::string tail : {"", "\n", "\n\n", "\n \n", "\r\n\r\n"}) {
    const fs::path path = file("tail.csv", "u\n1\n2" + tail);
    const Record record = read_csv(path, {"u"});
    EXPECT_EQ(record.columns[0], Eigen::Vector2d(1, 2)) << "tail of " << tail.size() << " bytes";
  }
}

TEST_F(CsvTableTest, SkipsUtf8ByteOrderMark) {
  const Record record = read_csv(file("bom.csv", "\xEF\xBB\xBFu,y\n1,2\n"), {"u"});
  EXPECT_EQ(record.columns[0](0), 1.0);
}

TEST_F(CsvTableTest, ColumnsNotChosenMayHoldText) {
  const Record record = read_csv(file("text.csv", "time,u\n12:00:01,0.5\nnoon,0.25\n"), {"u"});
  EXPECT_EQ(record.columns[0], Eigen::Vector2d(0.5, 0.25));
}

TEST_F(CsvTableTest, HeaderOnlyIsZeroSamplesWhenAllowed) {
  const Record record = read_csv(file("header.csv", "u,y\n"), {"u", "y"}, 0);
  EXPECT_EQ(record.samples(), 0u);
  EXPECT_EQ(record.columns.size(), 2u);
}

// ---------------------------------------------------------------------------------------------
// Reading: every way a file is rejected. Messages are compared whole: file, line, column, problem.

TEST_F(CsvTableTest, MissingFileIsAnError) {
  const fs::path path = dir_ / "absent.csv";
  EXPECT_EQ(data_error([&] { read_csv(path, {"u"}); }), path.string() + ": cannot open: No such file or directory");
}

TEST_F(CsvTableTest, DirectoryIsAnError) {
  EXPECT_EQ(data_error([&] { read_csv(dir_, {"u"}); }), dir_.string() + ": cannot read: Is a directory");
}

TEST_F(CsvTableTest, EmptyFileIsAnError) {
  for (const std::string content : {"", "\n", " \r\n\n"}) {
    const fs::path path = file("empty.csv", content);
    EXPECT_EQ(data_error([&] { read_csv(path, {"u"}); }), path.string() + ": empty file");
  }
}

TEST_F(CsvTableTest, EmptyHeaderLineIsAnError) {
  const fs::path path = file("data.csv", "\nu\n1\n");
  EXPECT_EQ(data_error([&] { read_csv(path, {"u"}); }),
            path.string() + ":1: empty header line (the first line must name the columns)");
}

TEST_F(CsvTableTest, NotANumberNamesLineAndColumn) {
  const fs::path path = file("data.csv", "u,y\n1,2\n3,4\n5,abc\n");
  EXPECT_EQ(data_error([&] { read_csv(path, {"u", "y"}); }), path.string() + ":4: column \"y\": not a number: \"abc\"");
}

TEST_F(CsvTableTest, MalformedNumbersAreErrors) {
  for (const std::string value : {"1.5.2", "0x10", "1e", "++1", "+-1", "+", "1_000", "1 2", "--1", "e5"}) {
    const fs::path path = file("data.csv", "u\n1\n" + value + "\n");
    EXPECT_EQ(data_error([&] { read_csv(path, {"u"}); }),
              path.string() + ":3: column \"u\": not a number: \"" + value + "\"");
  }
}

TEST_F(CsvTableTest, LongGarbageIsShortenedInTheMessage) {
  const std::string garbage(200, 'z');
  const fs::path path = file("data.csv", "u\n" + garbage + "\n");
  EXPECT_EQ(data_error([&] { read_csv(path, {"u"}); }),
            path.string() + ":2: column \"u\": not a number: \"" + std::string(40, 'z') + "...\"");
}

TEST_F(CsvTableTest, EmptyFieldIsAnError) {
  const fs::path path = file("data.csv", "u,y\n1,2\n3, \n");
  EXPECT_EQ(data_error([&] { read_csv(path, {"u", "y"}); }), path.string() + ":3: column \"y\": empty field");
}

TEST_F(CsvTableTest, NonFiniteValuesAreErrors) {
  for (const std::string value : {"nan", "NaN", "-nan", "inf", "-inf", "+inf", "infinity"}) {
    const fs::path path = file("data.csv", "u,y\n1,2\n3,4\n5,6\n" + value + ",8\n");
    EXPECT_EQ(data_error([&] { read_csv(path, {"u", "y"}); }),
              path.string() + ":5: column \"u\": not finite: \"" + value + "\"");
  }
}

TEST_F(CsvTableTest, OutOfRangeValuesAreErrors) {
  for (const std::string value : {"1e400", "-2e308", "1e-400"}) {
    const fs::path path = file("data.csv", "u\n" + value + "\n");
    EXPECT_EQ(data_error([&] { read_csv(path, {"u"}); }),
              path.string() + ":2: column \"u\": out of range: \"" + value + "\"");
  }
}

TEST_F(CsvTableTest, WrongFieldCountIsAnError) {
  const fs::path few = file("few.csv", "u,x,y\n1,2,3\n1,2,3\n1,2,3\n1,2,3\n1,2,3\n1,2\n1,2,3\n");
  EXPECT_EQ(data_error([&] { read_csv(few, {"u"}); }), few.string() + ":7: expected 3 fields, found 2");
  const fs::path many = file("many.csv", "u,y\n1,2\n1,2,\n");  // a trailing comma is one more field
  EXPECT_EQ(data_error([&] { read_csv(many, {"u"}); }), many.string() + ":3: expected 2 fields, found 3");
  const fs::path decimal_comma = file("comma.csv", "u,y\n1,5,2\n");
  EXPECT_EQ(data_error([&] { read_csv(decimal_comma, {"u"}); }),
            decimal_comma.string() + ":2: expected 2 fields, found 3");
}

TEST_F(CsvTableTest, MissingColumnListsTheColumns) {
  const fs::path path = file("data.csv", "u,x\n1,2\n");
  EXPECT_EQ(data_error([&] { read_csv(path, {"u", "y"}); }), path.string() + ": no column \"y\" (columns: u, x)");
}

TEST_F(CsvTableTest, MissingColumnHintsAtAnotherSeparator) {
  const fs::path path = file("data.csv", "u;y\n1;2\n");
  EXPECT_EQ(data_error([&] { read_csv(path, {"u"}); }),
            path.string() + ": no column \"u\" (columns: u;y); the file seems to use ';' or tabs between fields, "
                            "but only ',' is supported");
}

TEST_F(CsvTableTest, TooFewSamplesIsAnError) {
  const fs::path path = file("data.csv", "u\n1\n2\n3\n");
  EXPECT_EQ(data_error([&] { read_csv(path, {"u"}, 10); }), path.string() + ": 3 samples, need at least 10");
  EXPECT_EQ(read_csv(path, {"u"}, 3).samples(), 3u);
  const fs::path header_only = file("header.csv", "u\n");
  EXPECT_EQ(data_error([&] { read_csv(header_only, {"u"}); }), header_only.string() + ": 0 samples, need at least 1");
}

TEST_F(CsvTableTest, DuplicateHeaderNamesAreAnError) {
  const fs::path path = file("data.csv", "u,y,\"u\"\n1,2,3\n");
  EXPECT_EQ(data_error([&] { read_csv(path, {"y"}); }),
            path.string() + ":1: duplicate column name \"u\" (columns 1 and 3)");
}

TEST_F(CsvTableTest, EmptyHeaderNameIsAnError) {
  const fs::path path = file("data.csv", "u,y,\n1,2,3\n");
  EXPECT_EQ(data_error([&] { read_csv(path, {"u"}); }), path.string() + ":1: column 3 has an empty name");
}

TEST_F(CsvTableTest, EmptyLineInsideTheDataIsAnError) {
  for (const std::string blank : {"", "  ", "\r"}) {
    const fs::path path = file("data.csv", "u,y\n1,2\n" + blank + "\n3,4\n");
    EXPECT_EQ(data_error([&] { read_csv(path, {"u"}); }),
              path.string() + ":3: empty line inside the data (data continues on line 4)");
  }
}

TEST_F(CsvTableTest, BadQuotingIsAnError) {
  const fs::path unterminated = file("open.csv", "\"u,y\n1,2\n");
  EXPECT_EQ(data_error([&] { read_csv(unterminated, {"u"}); }), unterminated.string() + ":1: field 1: unterminated quote");
  const fs::path trailing = file("after.csv", "u,\"y\"z\n1,2\n");
  EXPECT_EQ(data_error([&] { read_csv(trailing, {"u"}); }),
            trailing.string() + ":1: field 2: unexpected text after the closing quote");
}

TEST_F(CsvTableTest, OldMacLineEndingsAreAnError) {
  const fs::path path = file("mac.csv", "u,y\r1,2\r3,4\r");
  EXPECT_EQ(data_error([&] { read_csv(path, {"u"}); }),
            path.string() + ":1: carriage return inside a line (only \\n and \\r\\n line endings are supported)");
}

TEST_F(CsvTableTest, BinaryContentIsAnError) {
  const fs::path path = file("binary.csv", std::string("u,y\n1,2\n\0\0\x01", 11) + "\n");
  EXPECT_EQ(data_error([&] { read_csv(path, {"u"}); }),
            path.string() + ":3: contains a NUL byte (not a text file, or UTF-16 text; save it as UTF-8)");
}

// ---------------------------------------------------------------------------------------------
// Writing

TEST_F(CsvTableTest, WritesHeaderAndShortestRoundTripNumbers) {
  Record record;
  record.add("u", Eigen::Vector3d(0.1, -2, 1e-5));
  record.add("y", Eigen::Vector3d(1.0 / 3.0, 1e21, -0.0));
  const fs::path path = dir_ / "out.csv";
  write_csv(path, record);
  EXPECT_EQ(text_of(path), "u,y\n0.1,0.3333333333333333\n-2,1e+21\n1e-05,-0\n");
}

TEST_F(CsvTableTest, RoundTripIsBitExact) {
  // Awkward values by construction, then random bit patterns over the whole finite range.
  std::vector<double> values = {0.1,  1.0 / 3.0, -0.0, 4.9e-324, -DBL_MIN, DBL_MAX, -DBL_MAX, std::numbers::pi, 1e21, 1e-7,
                                0.5,  123456789012345678.0, 2.2250738585072009e-308, -1.0, 1.0 - DBL_EPSILON / 2};
  std::mt19937_64 random(20240501);
  while (values.size() < 5000) {
    const double value = std::bit_cast<double>(random());
    if (std::isfinite(value)) values.push_back(value);
  }
  Eigen::VectorXd u = Eigen::Map<Eigen::VectorXd>(values.data(), static_cast<Eigen::Index>(values.size()));
  Eigen::VectorXd y = u.reverse();
  Record record;
  record.add("u", u);
  record.add("y", y);
  const fs::path path = dir_ / "round.csv";
  write_csv(path, record);
  const Record back = read_csv(path, {"u", "y"});
  ASSERT_EQ(back.samples(), values.size());
  for (Eigen::Index k = 0; k < u.size(); ++k) {
    ASSERT_EQ(bits(back.columns[0](k)), bits(u(k))) << "u, sample " << k;
    ASSERT_EQ(bits(back.columns[1](k)), bits(y(k))) << "y, sample " << k;
  }
}

TEST_F(CsvTableTest, QuotesNamesThatNeedIt) {
  Record record;
  record.add("a,b", Eigen::Vector2d(1, 2));
  record.add("say \"hi\"", Eigen::Vector2d(3, 4));
  record.add(" padded", Eigen::Vector2d(5, 6));
  const fs::path path = dir_ / "names.csv";
  write_csv(path, record);
  EXPECT_EQ(text_of(path), "\"a,b\",\"say \"\"hi\"\"\",\" padded\"\n1,3,5\n2,4,6\n");
  const Record back = read_csv(path, {"a,b", "say \"hi\"", " padded"});
  EXPECT_EQ(back.columns[2], Eigen::Vector2d(5, 6));
}

TEST_F(CsvTableTest, WritesAndReadsZeroSamples) {
  Record record;
  record.add("u", Eigen::VectorXd(0));
  const fs::path path = dir_ / "none.csv";
  write_csv(path, record);
  EXPECT_EQ(text_of(path), "u\n");
  EXPECT_EQ(read_csv(path, {"u"}, 0).samples(), 0u);
}

TEST_F(CsvTableTest, WritingNonFiniteValuesIsAnError) {
  Record record;
  record.add("u", Eigen::Vector3d(0, 1, 2));
  record.add("y", Eigen::Vector3d(0, 1, std::numeric_limits<double>::quiet_NaN()));
  const fs::path path = dir_ / "bad.csv";
  EXPECT_EQ(data_error([&] { write_csv(path, record); }), path.string() + ": column \"y\", sample 2: not finite (nan)");
  EXPECT_FALSE(fs::exists(path));  // checked before the file is touched
  record.columns[1](2) = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(data_error([&] { write_csv(path, record); }), path.string() + ": column \"y\", sample 2: not finite (inf)");
}

TEST_F(CsvTableTest, WritingUnreadableNamesIsAnError) {
  const fs::path path = dir_ / "bad.csv";
  Record duplicate;
  duplicate.add("u", Eigen::Vector2d(1, 2));
  duplicate.add("y", Eigen::Vector2d(1, 2));
  duplicate.add("u", Eigen::Vector2d(1, 2));
  EXPECT_EQ(data_error([&] { write_csv(path, duplicate); }),
            path.string() + ": duplicate column name \"u\" (columns 1 and 3)");
  Record unnamed;
  unnamed.add("u", Eigen::Vector2d(1, 2));
  unnamed.add("", Eigen::Vector2d(1, 2));
  EXPECT_EQ(data_error([&] { write_csv(path, unnamed); }), path.string() + ": column 2 has an empty name");
  Record broken;
  broken.add("u\ny", Eigen::Vector2d(1, 2));
  EXPECT_EQ(data_error([&] { write_csv(path, broken); }), path.string() + ": column 1: the name contains a line break");
  EXPECT_EQ(data_error([&] { write_csv(path, Record{}); }),
            path.string() + ": nothing to write (the record has no columns)");
}

TEST_F(CsvTableTest, UnwritablePathIsAnError) {
  Record record;
  record.add("u", Eigen::Vector2d(1, 2));
  const fs::path path = dir_ / "no-such-dir" / "out.csv";
  EXPECT_EQ(data_error([&] { write_csv(path, record); }), path.string() + ": cannot write: No such file or directory");
}

TEST_F(CsvTableTest, MalformedRecordIsAProgrammingError) {
  Record record;
  record.names = {"u", "y"};
  record.columns = {Eigen::Vector2d(1, 2), Eigen::Vector3d(1, 2, 3)};
  EXPECT_THROW(write_csv(dir_ / "x.csv", record), std::invalid_argument);
  record.names = {"u"};
  EXPECT_THROW(write_csv(dir_ / "x.csv", record), std::invalid_argument);
  EXPECT_THROW(read_csv(file("ok.csv", "u\n1\n"), {}), std::invalid_argument);
}

}  // namespace
}  // namespace panelbass::dsp

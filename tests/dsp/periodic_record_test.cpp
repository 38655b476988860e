// Periodic MIMO CSV files (the fine steering mirror's layout): grouped by realisation and period, read
// back as written; a missing column, an interleaved group or a short period refused, naming file and place.
#include "dsp/periodic_record.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "tests/dsp/data_error_message.h"
#include "tests/support/scratch_directory.h"

namespace panelbass::dsp {
namespace {

namespace fs = std::filesystem;

class PeriodicRecordTest : public testing_support::ScratchDirectoryTest {};

using testing::data_error;

PeriodicColumns two_by_one() {
  PeriodicColumns c;
  c.inputs = {"u1", "u2"};
  c.outputs = {"y1"};
  return c;
}

TEST_F(PeriodicRecordTest, ReadsRealizationsAndPeriodsAndWritesThemBack) {
  const fs::path path = file("p.csv",
                             "realization,period,n,u1,u2,y1\n"
                             "1,1,0,1,2,3\n1,1,1,4,5,6\n1,2,0,1.5,2,3\n1,2,1,4,5,7\n"
                             "2,1,0,7,8,9\n2,1,1,10,11,12\n2,2,0,7,8,9\n2,2,1,10,11,12\n");
  const PeriodicRecord r = read_periodic_csv(path, two_by_one(), 100.0);
  ASSERT_EQ(r.realizations(), 2u);
  ASSERT_EQ(r.periods(), 2u);
  ASSERT_EQ(r.period, 2);
  EXPECT_EQ(r.fs, 100.0);
  EXPECT_EQ(r.u[1][0](1, 1), 11.0);
  EXPECT_EQ(r.y[0][1](1, 0), 7.0);
  EXPECT_EQ(r.mean_input(0)(0, 0), 1.25);
  EXPECT_EQ(r.mean_output(0)(1, 0), 6.5);
  write_periodic_csv(dir_ / "back.csv", r);
  const PeriodicRecord back = read_periodic_csv(dir_ / "back.csv", two_by_one());
  for (std::size_t i = 0; i < 2; ++i) {
    for (std::size_t q = 0; q < 2; ++q) {
      EXPECT_EQ(back.u[i][q], r.u[i][q]);
      EXPECT_EQ(back.y[i][q], r.y[i][q]);
    }
  }
}

TEST_F(PeriodicRecordTest, RefusesBadFilesNamingTheFileAndPlace) {
  const fs::path missing = file("m.csv", "realization,period,n,u1,u2\n1,1,0,1,2\n");
  EXPECT_EQ(data_error([&] { read_periodic_csv(missing, two_by_one()); }),
            missing.string() + ": no column \"y1\" (columns: realization, period, n, u1, u2)");
  const fs::path interleaved = file("i.csv", "realization,period,u1,u2,y1\n1,1,0,0,0\n1,2,0,0,0\n1,1,0,0,0\n");
  EXPECT_EQ(data_error([&] { read_periodic_csv(interleaved, two_by_one()); }),
            interleaved.string() + ":4: realization 1, period 1 continues after other rows (the rows of a period, and the "
            "periods of a realization, must be contiguous)");
  const fs::path short_period = file("s.csv", "realization,period,u1,u2,y1\n1,1,0,0,0\n1,1,0,0,0\n1,2,0,0,0\n");
  EXPECT_EQ(data_error([&] { read_periodic_csv(short_period, two_by_one()); }),
            short_period.string() + ":4: realization 1, period 2 has 1 rows, the first period has 2");
  const fs::path fraction = file("f.csv", "realization,period,u1,u2,y1\n1.5,1,0,0,0\n");
  EXPECT_EQ(data_error([&] { read_periodic_csv(fraction, two_by_one()); }),
            fraction.string() + ":2: column \"realization\": not a whole number: 1.500000");
}

}  // namespace
}  // namespace panelbass::dsp

// io/csv.hpp: the one CSV writer. RFC 4180 quoting of every text cell and column key, formula-leading
// text neutralised (OWASP), numbers as numbers.
#include "cariesim/io/csv.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "cariesim/common/error.hpp"
#include "support/csv.hpp"

namespace cariesim::io {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

using test::parse_rfc4180;

class CsvTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("cariesim-io-csv-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST(CsvText, QuotesWhatNeedsItAndNeutralisesFormulas) {
  EXPECT_EQ(csv_text("plain"), "plain");
  EXPECT_EQ(csv_text(""), "");
  EXPECT_EQ(csv_text("a,b"), "\"a,b\"");
  EXPECT_EQ(csv_text("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(csv_text("two\nlines"), "\"two\nlines\"");
  // OWASP: =, +, -, @, TAB and CR at the start make a formula; a leading ' makes it text.
  EXPECT_EQ(csv_text("=1+2"), "'=1+2");
  EXPECT_EQ(csv_text("+1"), "'+1");
  EXPECT_EQ(csv_text("-1"), "'-1");
  EXPECT_EQ(csv_text("@SUM(A1)"), "'@SUM(A1)");
  EXPECT_EQ(csv_text("\tx"), "'\tx");
  EXPECT_EQ(csv_text("\rx"), "\"'\rx\"");
  EXPECT_EQ(csv_text("=HYPERLINK(\"http://x\",\"y\")"), "\"'=HYPERLINK(\"\"http://x\"\",\"\"y\"\")\"");
  // Inside a cell they are harmless.
  EXPECT_EQ(csv_text("a=b"), "a=b");
}

// Issue 26 item 7: a level named `evil,"x"\n=1+2` as a column key split the header into three
// columns and put a formula in the next line. Keys are text cells: quoted and neutralised, one field.
TEST_F(CsvTest, AHostileColumnKeyStaysOneField) {
  const std::string evil = "evil,\"x\"\n=1+2";
  CsvWriter csv(dir_ / "t.csv");
  csv.header({"participant", evil});
  csv.text("P1").number(0.5).end_row();
  csv.text("=cmd|' /C calc'!A0").number(-2.5).end_row();
  csv.close();
  const auto rows = parse_rfc4180(slurp(dir_ / "t.csv"));
  ASSERT_EQ(rows.size(), 3u) << slurp(dir_ / "t.csv");
  ASSERT_EQ(rows[0].size(), 2u);
  EXPECT_EQ(rows[0][1], evil);  // the key itself is not formula-leading: kept as it was
  EXPECT_EQ(rows[2][0], "'=cmd|' /C calc'!A0");
  // Numbers are numbers: a negative one is not neutralised.
  EXPECT_EQ(rows[2][1], "-2.5");
}

TEST_F(CsvTest, NumbersInEachForm) {
  CsvWriter csv(dir_ / "n.csv");
  csv.number(0.1).number(0.1f).number(1.0 / 3.0, 6).fixed(2.5, 3).integer(-7).empty();
  csv.number(std::numeric_limits<double>::quiet_NaN()).number(-std::numeric_limits<double>::infinity());
  csv.end_row();
  csv.close();
  EXPECT_EQ(slurp(dir_ / "n.csv"), "0.1,0.1,0.333333,2.500,-7,,nan,-inf\n");
}

TEST_F(CsvTest, ManyRowsAreAllWrittenAndFailuresNameTheFile) {
  {
    CsvWriter csv(dir_ / "big.csv");
    for (int i = 0; i < 100000; ++i) csv.integer(i).end_row();
    csv.close();
  }
  EXPECT_EQ(parse_rfc4180(slurp(dir_ / "big.csv")).size(), 100000u);
  // Without close() the destructor still writes what was buffered.
  {
    CsvWriter csv(dir_ / "unclosed.csv");
    csv.text("a").end_row();
  }
  EXPECT_EQ(slurp(dir_ / "unclosed.csv"), "a\n");
  try {
    CsvWriter csv(dir_ / "no" / "such" / "folder.csv");
    FAIL() << "wrote into a missing folder";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("folder.csv: cannot write"), std::string::npos) << e.what();
  }
}

// A full disk is reported at close (or at the block write), naming the file.
TEST_F(CsvTest, AFullDiskIsReported) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  CsvWriter csv("/dev/full");
  csv.text("x").end_row();
  try {
    csv.close();
    FAIL() << "a write to /dev/full succeeded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/full: write failed"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cariesim::io

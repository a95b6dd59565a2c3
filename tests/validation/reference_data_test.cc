// The validation reference data (server/validation/src/reference_data.cc): the CSV files of
// server/validation/data/, embedded at build time and parsed on first use, give the same doubles,
// bit for bit, as the C++ tables that were compiled into dysa_core before the files replaced
// them (the literals below are those tables' entries), and the parser rejects malformed files.
#include "reference_data.h"

#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "dysa/validation/validation.h"
#include "dysa/validation/validation_impact.h"

namespace dysa {
namespace {

// Bit-identical, not merely within a few ULPs.
void ExpectSameBits(double actual, double expected) {
  EXPECT_EQ(std::bit_cast<uint64_t>(actual), std::bit_cast<uint64_t>(expected))
      << actual << " vs " << expected;
}

TEST(ReferenceDataTest, EveryDataFileIsEmbedded) {
  std::vector<std::string> names;
  for (const ReferenceCsv& file : EmbeddedReferenceCsvs()) names.emplace_back(file.name);
  EXPECT_EQ(names, (std::vector<std::string>{"dam_break_martin_moyce_1952_front",
                                             "dam_break_martin_moyce_1952_height",
                                             "spheric_test2_marin_heights"}));
  for (const ReferenceCsv& file : EmbeddedReferenceCsvs()) {
    EXPECT_EQ(file.text.substr(0, 2), "# ") << file.name << ": the header comment comes first";
  }
  EXPECT_THROW(ReferenceCsvText("no_such_table"), std::logic_error);
}

TEST(ReferenceDataTest, MartinMoyceFrontIsTheFormerTable) {
  const std::vector<MartinMoyceRow>& rows = MartinMoyce1952Front();
  ASSERT_EQ(rows.size(), 14u);
  ExpectSameBits(rows.front().T, 0.00);
  ExpectSameBits(rows.front().Z, 1.00);
  ExpectSameBits(rows[1].T, 0.41);
  ExpectSameBits(rows[1].Z, 1.11);
  ExpectSameBits(rows[3].T, 1.19);  // kSurgeFrom's row
  ExpectSameBits(rows[3].Z, 1.44);
  ExpectSameBits(rows.back().T, 2.96);
  ExpectSameBits(rows.back().Z, 3.67);
  for (size_t i = 1; i < rows.size(); ++i) EXPECT_GT(rows[i].T, rows[i - 1].T);
}

TEST(ReferenceDataTest, MartinMoyceResidualHeightIsTheFormerTable) {
  const std::vector<MartinMoyceHeightRow>& rows = MartinMoyce1952ResidualHeight();
  ASSERT_EQ(rows.size(), 14u);
  ExpectSameBits(rows.front().tau, 0.56);
  ExpectSameBits(rows.front().H, 0.94);
  ExpectSameBits(rows[8].tau, 2.00);
  ExpectSameBits(rows[8].H, 0.50);
  ExpectSameBits(rows.back().tau, 3.44);
  ExpectSameBits(rows.back().H, 0.22);
  for (size_t i = 1; i < rows.size(); ++i) EXPECT_GT(rows[i].tau, rows[i - 1].tau);
}

TEST(ReferenceDataTest, MarinGaugeHeightsAreTheFormerTable) {
  const std::vector<GaugeRow>& rows = MarinGaugeHeights();
  ASSERT_EQ(rows.size(), 201u);  // 0 to 2 s by 10 ms
  // The first and last rows.
  ExpectSameBits(rows.front().t, 0.00);
  const double first[4] = {0.0004, 0.0005, 0.0003, 0.5467};
  for (int g = 0; g < kSphericGauges; ++g) ExpectSameBits(rows.front().height[g], first[g]);
  ExpectSameBits(rows.back().t, 2.00);
  const double last[4] = {0.2885, 0.2870, 0.1421, 0.1295};
  for (int g = 0; g < kSphericGauges; ++g) ExpectSameBits(rows.back().height[g], last[g]);
  // Each gauge's peak, where it is and what it is.
  struct Peak {
    size_t row;
    double t, height;
  };
  const Peak peaks[4] = {
      {162, 1.62, 0.3998}, {178, 1.78, 0.3398}, {108, 1.08, 0.1611}, {1, 0.01, 0.5507}};
  for (int g = 0; g < kSphericGauges; ++g) {
    size_t highest = 0;
    for (size_t i = 1; i < rows.size(); ++i) {
      if (rows[i].height[g] > rows[highest].height[g]) highest = i;
    }
    EXPECT_EQ(highest, peaks[g].row) << "H" << g + 1;
    ExpectSameBits(rows[highest].t, peaks[g].t);
    ExpectSameBits(rows[highest].height[g], peaks[g].height);
  }
  // Every value at once: the sum, in row order (t, then H1..H4), of the former table.
  double sum = 0;
  for (const GaugeRow& row : rows) {
    sum += row.t;
    for (double h : row.height) sum += h;
  }
  ExpectSameBits(sum, 0x1.5c7cd35a85875p+8);  // 348.48759999999976
  for (size_t i = 0; i < rows.size(); ++i) EXPECT_NEAR(rows[i].t, 0.01 * double(i), 1e-12);
  // H4 stands in the reservoir: about the initial depth at t = 0 (the gauge reads 0.547 m); the
  // others are dry until the water passes (H3, nearest the dam, first).
  EXPECT_NEAR(rows[0].height[3], kSphericDepth, 0.005);
  for (int g = 0; g < 3; ++g) EXPECT_LT(rows[0].height[g], 0.001);
  EXPECT_GT(rows[20].height[2], 0.01);  // t = 0.2 s
  EXPECT_LT(rows[20].height[1], 0.001);
}

TEST(ReferenceDataTest, ParserReadsCommentsHeaderAndRows) {
  const auto rows = ParseReferenceCsv("# source\n# units\nT, Z\r\n0.41,1.11\n\n 2.96 ,3.67\n",
                                      {"T", "Z"}, "test");
  ASSERT_EQ(rows.size(), 2u);
  ExpectSameBits(rows[0][0], 0.41);
  ExpectSameBits(rows[0][1], 1.11);
  ExpectSameBits(rows[1][0], 2.96);
  ExpectSameBits(rows[1][1], 3.67);
}

TEST(ReferenceDataTest, ParserRejectsMalformedFiles) {
  const std::vector<std::string> columns = {"T", "Z"};
  EXPECT_THROW(ParseReferenceCsv("# only a comment\n", columns, "test"), std::runtime_error);
  EXPECT_THROW(ParseReferenceCsv("T,X\n0,1\n", columns, "test"), std::runtime_error);
  EXPECT_THROW(ParseReferenceCsv("T,Z\n0,1,2\n", columns, "test"), std::runtime_error);
  EXPECT_THROW(ParseReferenceCsv("T,Z\n0\n", columns, "test"), std::runtime_error);
  EXPECT_THROW(ParseReferenceCsv("T,Z\n0,1x\n", columns, "test"), std::runtime_error);
  EXPECT_THROW(ParseReferenceCsv("T,Z\n0,\n", columns, "test"), std::runtime_error);
  try {
    ParseReferenceCsv("T,Z\n0,1\n0,one\n", columns, "table");
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("table.csv, line 3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dysa

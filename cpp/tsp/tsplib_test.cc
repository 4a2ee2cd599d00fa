#include "tsp/tsplib.h"

#include <gtest/gtest.h>

#include "common/error.h"

namespace mound::tsp {
namespace {

const std::string kShared = MOUND_SHARED_DATA;

TEST(TsplibTest, OptimalTourOfEil51HasTheKnownLength) {
  const TsplibInstance inst = ReadTsplib(kShared + "/tsplib/eil51.tsp");
  EXPECT_EQ(inst.dimension, 51);
  EXPECT_EQ(inst.edge_weight_type, "EUC_2D");
  const std::vector<int> tour = ReadTsplibTour(kShared + "/tsplib/eil51.opt.tour");
  EXPECT_EQ(TourLength(*inst.problem, tour), 426);
}

TEST(TsplibTest, ExplicitFormatsAgreeWithEachOther) {
  // The same 4-node matrix written in three formats.
  const std::string head = "NAME: t\nTYPE: TSP\nDIMENSION: 4\nEDGE_WEIGHT_TYPE: EXPLICIT\n";
  const auto full = ParseTsplib(head +
                                    "EDGE_WEIGHT_FORMAT: FULL_MATRIX\nEDGE_WEIGHT_SECTION\n"
                                    "0 1 2 3\n1 0 4 5\n2 4 0 6\n3 5 6 0\nEOF\n",
                                "full");
  const auto upper = ParseTsplib(head +
                                     "EDGE_WEIGHT_FORMAT : UPPER_ROW\nEDGE_WEIGHT_SECTION\n"
                                     "1 2 3\n4 5\n6\n",
                                 "upper");
  const auto lower = ParseTsplib(head +
                                     "EDGE_WEIGHT_FORMAT: LOWER_DIAG_ROW\n"
                                     "EDGE_WEIGHT_SECTION\n0 1 0 2 4 0 3 5 6 0\nEOF\n",
                                 "lower");
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      EXPECT_EQ(upper.problem->Dist(i, j), full.problem->Dist(i, j));
      EXPECT_EQ(lower.problem->Dist(i, j), full.problem->Dist(i, j));
    }
  EXPECT_EQ(full.problem->Dist(2, 3), 6);
}

TEST(TsplibTest, OplibExtensionsAreRead) {
  const auto inst = ReadTsplib(kShared + "/oplib/instances/gen1/gr48-gen1-50.oplib");
  EXPECT_EQ(inst.type, "OP");
  EXPECT_EQ(inst.dimension, 48);
  EXPECT_DOUBLE_EQ(inst.cost_limit, 2523);
  ASSERT_EQ(inst.scores.size(), 48u);
  EXPECT_EQ(inst.depot, 0);
}

TEST(TsplibTest, MalformedInputNamesTheLine) {
  try {
    ParseTsplib(
        "NAME: x\nDIMENSION: 2\nEDGE_WEIGHT_TYPE: EUC_2D\nNODE_COORD_SECTION\n1 0 0\n2 a 1\n",
        "bad.tsp");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.tsp:6"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ParseTsplib("TYPE: ATSP\nDIMENSION: 3\n", "a"), InputError);
  EXPECT_THROW(ParseTsplib("DIMENSION: 3\nEDGE_WEIGHT_TYPE: XRAY\n", "a"), InputError);
  EXPECT_THROW(
      ParseTsplib("DIMENSION: 3\nEDGE_WEIGHT_TYPE: EUC_2D\nNODE_COORD_SECTION\n1 0 0\n", "a"),
      InputError);
}

}  // namespace
}  // namespace mound::tsp

// PLY files: a written cloud reads back; ascii and big-endian files read; every malformed
// file is an InputError naming the file (and the line or vertex).
#include "geometry/ply.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>

#include "common/error.h"

namespace mound::geometry {
namespace {

std::string Temp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("mound_ply_test_" + name)).string();
}

void Write(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

std::string ErrorOf(const std::string& path) {
  try {
    ReadPly(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Ply, WrittenCloudReadsBack) {
  PlyCloud c;
  c.xyz = {{1.5, -2.25, 3.0}, {0, 0, 0}, {1e3, 2e3, -5}};
  c.rgb = {{255, 0, 10}, {1, 2, 3}, {9, 8, 7}};
  c.scalars["distance"] = {0.5, 0.25, 4.0};
  c.scalars["track_length"] = {2, 7, 40000};
  c.int_scalars = {"track_length"};
  c.comments = {"mound.test v1"};
  const std::string p = Temp("rt.ply");
  WritePly(p, c);
  const PlyCloud r = ReadPly(p);
  ASSERT_EQ(r.xyz.size(), 3u);
  for (size_t i = 0; i < 3; ++i) EXPECT_LT((r.xyz[i] - c.xyz[i]).norm(), 1e-4);
  EXPECT_EQ(r.rgb, c.rgb);
  EXPECT_EQ(r.scalars.at("distance"), c.scalars.at("distance"));
  EXPECT_EQ(r.scalars.at("track_length"), c.scalars.at("track_length"));
  EXPECT_EQ(r.int_scalars, c.int_scalars);  // written as int, read back as an integer field
  EXPECT_EQ(r.comments, c.comments);
  c.scalars["track_length"][1] = 7.5;  // an int field must hold integers
  EXPECT_THROW(WritePly(p, c), InternalError);
}

TEST(Ply, AsciiAndBigEndianAndSkippedElements) {
  const std::string a = Temp("ascii.ply");
  Write(a,
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
        "property double z\nproperty int track_length\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n1 2 3 4\n-1 -2 -3.5 2\n3 0 1 2\n");
  const PlyCloud c = ReadPly(a);
  ASSERT_EQ(c.xyz.size(), 2u);
  EXPECT_EQ(c.xyz[1], Eigen::Vector3d(-1, -2, -3.5));
  EXPECT_TRUE(c.rgb.empty());
  EXPECT_EQ(c.scalars.at("track_length"), (std::vector<double>{4, 2}));
  // Big-endian float 1.0 = 3f 80 00 00; a fixed-size element before the vertices.
  std::string b =
      "ply\nformat binary_big_endian 1.0\nelement camera 1\nproperty short id\n"
      "element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  b += std::string("\x00\x07", 2);
  b += std::string("\x3f\x80\x00\x00\x40\x00\x00\x00\xc0\x40\x00\x00", 12);
  const std::string bp = Temp("be.ply");
  Write(bp, b);
  const PlyCloud be = ReadPly(bp);
  ASSERT_EQ(be.xyz.size(), 1u);
  EXPECT_EQ(be.xyz[0], Eigen::Vector3d(1, 2, -3));
}

TEST(Ply, BadFilesNameTheProblem) {
  EXPECT_NE(ErrorOf(Temp("missing.ply")).find("cannot open"), std::string::npos);
  const std::string p = Temp("bad.ply");
  Write(p, "solid cube\n");
  EXPECT_NE(ErrorOf(p).find("not a PLY file"), std::string::npos);
  Write(
      p,
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n" +
          std::string(20, '\0'));
  EXPECT_NE(ErrorOf(p).find("truncated: vertex 1 of 3"), std::string::npos) << ErrorOf(p);
  Write(p,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float "
        "y\nend_header\n1 2\n");
  EXPECT_NE(ErrorOf(p).find("lacks x, y or z"), std::string::npos);
  Write(p,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty "
        "float z\n"
        "end_header\n1 nan 2\n");
  EXPECT_NE(ErrorOf(p).find("vertex 0: non-finite"), std::string::npos) << ErrorOf(p);
  Write(p, "ply\nformat ascii 1.0\nelement vertex many\nend_header\n");
  EXPECT_NE(ErrorOf(p).find(":3: element vertex: bad count"), std::string::npos) << ErrorOf(p);
  Write(p,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty "
        "float z\n");
  EXPECT_NE(ErrorOf(p).find("no end_header"), std::string::npos);
  Write(p, "ply\nformat ebcdic 1.0\n");
  EXPECT_NE(ErrorOf(p).find("unknown format"), std::string::npos);
  Write(p,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty "
        "float z\n"
        "end_header\n1 2 x\n");
  EXPECT_NE(ErrorOf(p).find("bad value 'x'"), std::string::npos);
}

}  // namespace
}  // namespace mound::geometry

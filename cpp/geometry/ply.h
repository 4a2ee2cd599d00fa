// PLY point clouds (Turk 1994; the format of points.ply, reference.ply, aligned.ply):
// a strict reader for the vertex element of ascii, binary_little_endian and
// binary_big_endian files, and a binary little-endian writer.
//
// Reader: x, y, z are required (any numeric type); red, green, blue (uchar) are read when
// present; every other scalar vertex property is kept by name as a double. Elements before
// the vertex element must have fixed-size properties (they are skipped); elements after it
// are ignored. Anything else — not a PLY file, an unknown format or type, a list property
// in the vertex element, a count that does not parse, a file shorter than its header
// says, a non-finite coordinate — is an InputError naming the file and the line or vertex.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <istream>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace mound::geometry {

struct PlyCloud {
  std::vector<Eigen::Vector3d> xyz;
  std::vector<std::array<uint8_t, 3>> rgb;             // empty when the file has no colours
  std::map<std::string, std::vector<double>> scalars;  // other vertex properties, by name
  std::set<std::string> int_scalars;  // those of `scalars` of an integer type in the file
  std::vector<std::string> comments;
};

PlyCloud ReadPly(const std::string& path);
// The same from a stream; `path` names it in error messages (InputError "path:line: ...").
PlyCloud ParsePly(std::istream& in, const std::string& path);

// Binary little-endian: float x y z, uchar red green blue when `rgb` is not empty, then
// one scalar field after another in the map's order, int for those named in
// `int_scalars` (their values must be integers in int32's range), float for the others;
// comments as given. Atomic. The one PLY writer of the C++ side.
void WritePly(const std::string& path, const PlyCloud& cloud);

}  // namespace mound::geometry

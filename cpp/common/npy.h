// NumPy .npy arrays (format version 1.0/2.0/3.0, C order, little-endian): the way the Python
// side hands dense grids (heightfields, textures, scene blocks) to the C++ tools and gets depth
// maps and logits back.
// Reference: numpy/lib/format.py ("magic string, header length, a Python dict literal
// with descr, fortran_order and shape, padded to 64 bytes, then the raw data").
#pragma once

#include <cstdint>
#include <istream>
#include <string>
#include <vector>

namespace mound {

struct NpyArray {
  std::string descr;  // "<f4", "<f8" or "|u1"
  std::vector<size_t> shape;
  std::vector<unsigned char> data;  // raw little-endian elements, C order

  size_t Count() const;
  // The elements converted to double (any supported descr).
  std::vector<double> AsDouble() const;
};

// `n` little-endian elements of type `descr` ("<f4", "<f8" or "|u1") at `data`, converted
// to double into `out` (NpyArray::AsDouble; streamed blocks).
void ElementsToDouble(const std::string& descr, const unsigned char* data, size_t n, double* out);

// Reads `path`; throws InputError naming the file for a bad magic, header, dtype, Fortran
// order or a size that does not match the shape.
NpyArray ReadNpy(const std::string& path);
// The same from a stream; `path` names it in error messages.
NpyArray ParseNpy(std::istream& in, const std::string& path);

// Write a float32 / float64 array atomically (`values` holds the product of `shape`).
void WriteNpyFloat32(const std::string& path, const std::vector<size_t>& shape,
                     const std::vector<float>& values);
void WriteNpyFloat64(const std::string& path, const std::vector<size_t>& shape,
                     const std::vector<double>& values);

}  // namespace mound

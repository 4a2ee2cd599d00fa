#include "common/npy.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>

#include "common/atomic_file.h"
#include "common/error.h"

namespace mound {
namespace {

size_t ElementSize(const std::string& descr) {
  if (descr == "<f4") return 4;
  if (descr == "<f8") return 8;
  if (descr == "|u1" || descr == "<u1") return 1;
  return 0;
}

}  // namespace

size_t NpyArray::Count() const {
  size_t n = 1;
  for (size_t s : shape) n *= s;
  return n;
}

void ElementsToDouble(const std::string& descr, const unsigned char* data, size_t n, double* out) {
  if (n == 0) return;  // no data (memcpy of a null pointer is UB)
  if (descr == "<f4") {
    for (size_t i = 0; i < n; ++i) {
      float f;
      std::memcpy(&f, data + 4 * i, 4);
      out[i] = f;
    }
  } else if (descr == "<f8") {
    std::memcpy(out, data, 8 * n);
  } else {
    for (size_t i = 0; i < n; ++i) out[i] = data[i];
  }
}

std::vector<double> NpyArray::AsDouble() const {
  std::vector<double> out(Count());
  ElementsToDouble(descr, data.data(), out.size(), out.data());
  return out;
}

namespace {

// The header is a Python dict literal; numpy writes it in one form ("{'descr': '<f4',
// 'fortran_order': False, 'shape': (3, 4), }"). A small scanner (no regular expressions:
// std::regex recurses per character and overflows the stack on long inputs) finds the
// value after `'key':` and stops at the first delimiter.
std::string ValueAfter(const std::string& header, const std::string& key, const std::string& path) {
  const std::string quoted = "'" + key + "'";
  const size_t k = header.find(quoted);
  if (k == std::string::npos) throw InputError(path + ": not a valid .npy: no " + key);
  size_t i = header.find_first_not_of(" \t", k + quoted.size());
  if (i == std::string::npos || header[i] != ':') {
    throw InputError(path + ": not a valid .npy: no ':' after " + key);
  }
  i = header.find_first_not_of(" \t", i + 1);
  if (i == std::string::npos) throw InputError(path + ": not a valid .npy: no value for " + key);
  const char open = header[i];
  const char close = open == '\'' ? '\'' : open == '(' ? ')' : '\0';
  if (close != '\0') {
    const size_t j = header.find(close, i + 1);
    if (j == std::string::npos) throw InputError(path + ": not a valid .npy: unterminated " + key);
    return header.substr(i + 1, j - i - 1);
  }
  const size_t j = header.find_first_of(",}", i);
  return header.substr(i, (j == std::string::npos ? header.size() : j) - i);
}

}  // namespace

NpyArray ReadNpy(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open (" + std::strerror(errno) + ")");
  return ParseNpy(in, path);
}

NpyArray ParseNpy(std::istream& in, const std::string& path) {
  auto bad = [&](const std::string& why) {
    return InputError(path + ": not a valid .npy: " + why);
  };
  char lead[12];
  in.read(lead, 10);
  if (in.gcount() < 10 || std::string(lead, 6) != "\x93NUMPY") throw bad("bad magic");
  const int major = static_cast<unsigned char>(lead[6]);
  size_t header_len = 0;
  if (major == 1) {
    header_len = static_cast<unsigned char>(lead[8]) | (static_cast<unsigned char>(lead[9]) << 8);
  } else if (major == 2 || major == 3) {
    in.read(lead + 10, 2);
    if (in.gcount() < 2) throw bad("truncated header");
    for (int k = 0; k < 4; ++k)
      header_len |= size_t(static_cast<unsigned char>(lead[8 + k])) << (8 * k);
  } else {
    throw bad("unknown format version " + std::to_string(major));
  }
  // numpy itself refuses headers over 10,000 bytes unless told otherwise; ours are < 200.
  constexpr size_t kMaxHeader = 65536;
  if (header_len > kMaxHeader) {
    throw bad("header of " + std::to_string(header_len) + " bytes (at most " +
              std::to_string(kMaxHeader) + ")");
  }
  std::string header(header_len, '\0');
  in.read(header.data(), static_cast<std::streamsize>(header_len));
  if (static_cast<size_t>(in.gcount()) != header_len) throw bad("truncated header");

  NpyArray a;
  a.descr = ValueAfter(header, "descr", path);
  const size_t esize = ElementSize(a.descr);
  if (esize == 0) {
    throw bad("dtype " + a.descr.substr(0, 32) + " (expected <f4, <f8 or |u1)");
  }
  const std::string order = ValueAfter(header, "fortran_order", path);
  if (order == "True") throw InputError(path + ": Fortran-ordered arrays are not supported");
  if (order != "False") throw bad("fortran_order must be True or False");
  const std::string dims = ValueAfter(header, "shape", path);
  // At most 2^31 elements (16 GiB of float64, far beyond any grid of ours) in at most 8
  // dimensions: no overflow below, and a clear message for a corrupt header.
  constexpr unsigned long long kMaxElements = 1ULL << 31;
  constexpr size_t kMaxDims = 8;
  unsigned long long count = 1;
  size_t i = 0;
  while (i < dims.size()) {
    if (dims[i] == ' ' || dims[i] == ',') {
      ++i;
      continue;
    }
    if (!std::isdigit(static_cast<unsigned char>(dims[i]))) throw bad("shape must list integers");
    size_t j = i;
    while (j < dims.size() && std::isdigit(static_cast<unsigned char>(dims[j]))) ++j;
    if (j - i > 12) throw bad("shape entry " + dims.substr(i, 16) + "... too large");
    if (a.shape.size() == kMaxDims) throw bad("more than 8 dimensions");
    a.shape.push_back(std::stoull(dims.substr(i, j - i)));
    count *= std::max<unsigned long long>(a.shape.back(), 1);
    if (count > kMaxElements) throw bad("shape has more than 2^31 elements");
    i = j;
  }
  const size_t bytes = a.Count() * esize;
  // Read exactly what the shape needs, in chunks (the vector grows only as data comes, so a
  // lying header cannot make it allocate), then insist on the end of the file.
  constexpr size_t kChunk = size_t{1} << 20;
  while (a.data.size() < bytes) {
    const size_t want = std::min(kChunk, bytes - a.data.size());
    const size_t at = a.data.size();
    a.data.resize(at + want);
    in.read(reinterpret_cast<char*>(a.data.data() + at), static_cast<std::streamsize>(want));
    const size_t got = static_cast<size_t>(in.gcount());
    if (got < want) {
      throw bad("data has " + std::to_string(at + got) + " bytes, shape needs " +
                std::to_string(bytes));
    }
  }
  if (in.peek() != std::char_traits<char>::eof()) {
    throw bad("more data than the shape needs (" + std::to_string(bytes) + " bytes)");
  }
  return a;
}

namespace {

void WriteNpy(const std::string& path, const std::vector<size_t>& shape, const char* descr,
              const void* data, size_t bytes) {
  std::string dims;
  for (size_t i = 0; i < shape.size(); ++i) dims += (i ? ", " : "") + std::to_string(shape[i]);
  if (shape.size() == 1) dims += ",";
  std::string header =
      std::string("{'descr': '") + descr + "', 'fortran_order': False, 'shape': (" + dims + "), }";
  const size_t total = 10 + header.size() + 1;
  header += std::string((64 - total % 64) % 64, ' ') + "\n";
  std::string out = "\x93NUMPY";
  out += '\x01';
  out += '\x00';
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>(header.size() >> 8);
  out += header;
  out.append(static_cast<const char*>(data), bytes);
  WriteFileAtomic(path, out);
}

}  // namespace

void WriteNpyFloat32(const std::string& path, const std::vector<size_t>& shape,
                     const std::vector<float>& values) {
  WriteNpy(path, shape, "<f4", values.data(), values.size() * sizeof(float));
}

void WriteNpyFloat64(const std::string& path, const std::vector<size_t>& shape,
                     const std::vector<double>& values) {
  WriteNpy(path, shape, "<f8", values.data(), values.size() * sizeof(double));
}

}  // namespace mound

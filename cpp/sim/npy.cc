#include "sim/npy.h"

#include <algorithm>
#include <cstring>
#include <regex>

#include "common/atomic_file.h"
#include "common/error.h"

namespace mound::sim {
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

std::vector<double> NpyArray::AsDouble() const {
  const size_t n = Count();
  std::vector<double> out(n);
  if (descr == "<f4") {
    for (size_t i = 0; i < n; ++i) {
      float f;
      std::memcpy(&f, data.data() + 4 * i, 4);
      out[i] = f;
    }
  } else if (descr == "<f8") {
    std::memcpy(out.data(), data.data(), 8 * n);
  } else {
    for (size_t i = 0; i < n; ++i) out[i] = data[i];
  }
  return out;
}

NpyArray ReadNpy(const std::string& path) {
  const std::string raw = ReadFile(path);
  auto bad = [&](const std::string& why) { return InputError(path + ": not a valid .npy: " + why); };
  if (raw.size() < 10 || raw.compare(0, 6, "\x93NUMPY") != 0) throw bad("bad magic");
  const int major = static_cast<unsigned char>(raw[6]);
  size_t header_len = 0;
  size_t offset = 0;
  if (major == 1) {
    header_len = static_cast<unsigned char>(raw[8]) | (static_cast<unsigned char>(raw[9]) << 8);
    offset = 10;
  } else if (major == 2 || major == 3) {
    if (raw.size() < 12) throw bad("truncated header");
    for (int k = 0; k < 4; ++k) header_len |= size_t(static_cast<unsigned char>(raw[8 + k])) << (8 * k);
    offset = 12;
  } else {
    throw bad("unknown format version " + std::to_string(major));
  }
  if (raw.size() < offset + header_len) throw bad("truncated header");
  const std::string header = raw.substr(offset, header_len);
  std::smatch m;
  NpyArray a;
  if (!std::regex_search(header, m, std::regex("'descr'\\s*:\\s*'([^']*)'"))) throw bad("no descr");
  a.descr = m[1];
  const size_t esize = ElementSize(a.descr);
  if (esize == 0) throw bad("dtype " + a.descr + " (expected <f4, <f8 or |u1)");
  if (!std::regex_search(header, m, std::regex("'fortran_order'\\s*:\\s*(True|False)")))
    throw bad("no fortran_order");
  if (m[1] == "True") throw InputError(path + ": Fortran-ordered arrays are not supported");
  if (!std::regex_search(header, m, std::regex("'shape'\\s*:\\s*\\(([^)]*)\\)"))) throw bad("no shape");
  const std::string dims = m[1];
  std::regex num("\\d+");
  // At most 2^32 elements of at most 8 bytes: no overflow below, and a clear message for
  // a corrupt header that claims more than any real grid.
  const unsigned long long kMaxElements = 1ULL << 32;
  unsigned long long count = 1;
  for (auto it = std::sregex_iterator(dims.begin(), dims.end(), num); it != std::sregex_iterator();
       ++it) {
    if (it->str().size() > 12) throw bad("shape entry " + it->str() + " too large");
    a.shape.push_back(std::stoull(it->str()));
    count *= std::max<unsigned long long>(a.shape.back(), 1);
    if (count > kMaxElements) throw bad("shape has more than 2^32 elements");
  }
  const size_t bytes = a.Count() * esize;
  if (raw.size() - offset - header_len != bytes) {
    throw bad("data has " + std::to_string(raw.size() - offset - header_len) + " bytes, shape needs " +
              std::to_string(bytes));
  }
  a.data.assign(raw.begin() + offset + header_len, raw.end());
  return a;
}

void WriteNpyFloat32(const std::string& path, const std::vector<size_t>& shape,
                     const std::vector<float>& values) {
  std::string dims;
  for (size_t i = 0; i < shape.size(); ++i) dims += (i ? ", " : "") + std::to_string(shape[i]);
  if (shape.size() == 1) dims += ",";
  std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': (" + dims + "), }";
  const size_t total = 10 + header.size() + 1;
  header += std::string((64 - total % 64) % 64, ' ') + "\n";
  std::string out = "\x93NUMPY";
  out += '\x01';
  out += '\x00';
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>(header.size() >> 8);
  out += header;
  out.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
  WriteFileAtomic(path, out);
}

}  // namespace mound::sim

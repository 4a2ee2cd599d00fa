#include "geometry/ply.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "common/atomic_file.h"
#include "common/error.h"

namespace mound::geometry {
namespace {

struct Property {
  std::string name, type;
  int size = 0;  // bytes
};

int TypeSize(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" || t == "float32")
    return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

double Decode(const char* p, const std::string& t, bool swap) {
  char b[8];
  const int n = TypeSize(t);
  for (int i = 0; i < n; ++i) b[i] = swap ? p[n - 1 - i] : p[i];
  auto get = [&](auto v) {
    std::memcpy(&v, b, sizeof v);
    return static_cast<double>(v);
  };
  if (t == "char" || t == "int8") return get(int8_t{});
  if (t == "uchar" || t == "uint8") return get(uint8_t{});
  if (t == "short" || t == "int16") return get(int16_t{});
  if (t == "ushort" || t == "uint16") return get(uint16_t{});
  if (t == "int" || t == "int32") return get(int32_t{});
  if (t == "uint" || t == "uint32") return get(uint32_t{});
  if (t == "float" || t == "float32") return get(float{});
  return get(double{});
}

struct Element {
  std::string name;
  long long count = 0;
  std::vector<Property> props;
  bool has_list = false;
};

}  // namespace

namespace {
constexpr long long kMaxElementCount = 500000000LL;  // 5 * 10^8: far above any cloud of ours
}  // namespace

PlyCloud ReadPly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the file");
  return ParsePly(in, path);
}

namespace {

struct Header {
  std::string format;  // ascii, binary_little_endian or binary_big_endian
  std::vector<Element> elements;
};

// The header up to end_header (its comments into `comments`), `*line_no` its last line.
Header ReadHeader(std::istream& in, const std::string& path, int* line_no,
                  std::vector<std::string>* comments) {
  auto fail = [&](int line, const std::string& what) {
    throw InputError(path + ":" + std::to_string(line) + ": " + what);
  };
  std::string line;
  int& ln = *line_no;
  if (!std::getline(in, line) || (line != "ply" && line != "ply\r"))
    fail(1, "not a PLY file (no 'ply' magic line)");
  ++ln;
  Header h;
  std::string& format = h.format;
  std::vector<Element>& elements = h.elements;
  bool ended = false;
  while (std::getline(in, line)) {
    ++ln;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "format") {
      std::string version;
      ls >> format >> version;
      if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian")
        fail(ln, "unknown format '" + format + "'");
    } else if (word == "comment" || word == "obj_info") {
      comments->push_back(line.size() > 8 ? line.substr(8) : "");
    } else if (word == "element") {
      Element e;
      std::string count;
      ls >> e.name >> count;
      char* end = nullptr;
      e.count = std::strtoll(count.c_str(), &end, 10);
      if (count.empty() || *end != '\0' || e.count < 0 || e.count > kMaxElementCount) {
        fail(ln, "element " + e.name + ": bad count '" + count + "' (0.." +
                     std::to_string(kMaxElementCount) + ")");
      }
      elements.push_back(e);
    } else if (word == "property") {
      if (elements.empty()) fail(ln, "property before any element");
      std::string type, name;
      ls >> type;
      if (type == "list") {
        elements.back().has_list = true;
        continue;
      }
      ls >> name;
      if (TypeSize(type) == 0 || name.empty()) fail(ln, "bad property '" + line + "'");
      elements.back().props.push_back({name, type, TypeSize(type)});
    } else if (word == "end_header") {
      ended = true;
      break;
    } else if (!word.empty()) {
      fail(ln, "unexpected header line '" + line + "'");
    }
  }
  if (!ended) fail(ln, "no end_header");
  if (format.empty()) fail(ln, "no format line");
  return h;
}

// The vertex element's columns: x, y, z and (8-bit) red, green, blue; -1 where absent.
struct Columns {
  int x = -1, y = -1, z = -1, r = -1, g = -1, b = -1;
};

Columns FindColumns(const Element& v) {
  Columns c;
  for (size_t k = 0; k < v.props.size(); ++k) {
    const std::string& n = v.props[k].name;
    const int kk = static_cast<int>(k);
    if (n == "x")
      c.x = kk;
    else if (n == "y")
      c.y = kk;
    else if (n == "z")
      c.z = kk;
    else if (n == "red" && v.props[k].type.find("char") != std::string::npos)
      c.r = kk;
    else if (n == "green" && v.props[k].type.find("char") != std::string::npos)
      c.g = kk;
    else if (n == "blue" && v.props[k].type.find("char") != std::string::npos)
      c.b = kk;
  }
  return c;
}

}  // namespace

PlyCloud ParsePly(std::istream& in, const std::string& path) {
  auto fail = [&](int line, const std::string& what) {
    throw InputError(path + ":" + std::to_string(line) + ": " + what);
  };
  std::string line;
  int ln = 0;
  PlyCloud cloud;
  const Header head = ReadHeader(in, path, &ln, &cloud.comments);
  const std::string& format = head.format;
  const std::vector<Element>& elements = head.elements;
  size_t vi = elements.size();
  for (size_t i = 0; i < elements.size(); ++i)
    if (elements[i].name == "vertex") {
      vi = i;
      break;
    }
  if (vi == elements.size()) fail(ln, "no vertex element");
  const Element& v = elements[vi];
  if (v.has_list) fail(ln, "element vertex: list properties are not supported");
  const Columns col = FindColumns(v);
  const int ix = col.x, iy = col.y, iz = col.z, ir = col.r, ig = col.g, ib = col.b;
  if (ix < 0 || iy < 0 || iz < 0) fail(ln, "element vertex lacks x, y or z");
  const bool colours = ir >= 0 && ig >= 0 && ib >= 0;
  const bool binary = format != "ascii";
  const bool swap = format == "binary_big_endian";  // this code runs on little-endian machines
  // Skip the elements before the vertex element.
  for (size_t i = 0; i < vi; ++i) {
    const Element& e = elements[i];
    if (e.has_list)
      fail(ln, "element " + e.name + " before vertex has list properties (unsupported)");
    if (binary) {
      long long bytes = 0;
      for (const Property& p : e.props) bytes += p.size;
      in.seekg(bytes * e.count, std::ios::cur);
    } else {
      for (long long k = 0; k < e.count && in; ++k) std::getline(in, line);
    }
    if (!in) throw InputError(path + ": truncated in element " + e.name);
  }
  int record = 0;
  for (const Property& p : v.props) record += p.size;
  // Reserve no more than a million up front: the count is the file's claim, the data may
  // not be there.
  const size_t reserve = static_cast<size_t>(std::min<long long>(v.count, 1 << 20));
  cloud.xyz.reserve(reserve);
  std::vector<std::vector<double>*> extra(v.props.size(), nullptr);
  for (size_t k = 0; k < v.props.size(); ++k) {
    const int kk = static_cast<int>(k);
    if (kk == ix || kk == iy || kk == iz || (colours && (kk == ir || kk == ig || kk == ib)))
      continue;
    extra[k] = &cloud.scalars[v.props[k].name];
    extra[k]->reserve(reserve);
    const std::string& t = v.props[k].type;
    if (t != "float" && t != "float32" && t != "double" && t != "float64")
      cloud.int_scalars.insert(v.props[k].name);
  }
  std::vector<char> buf(static_cast<size_t>(record));
  std::vector<double> val(v.props.size());
  for (long long n = 0; n < v.count; ++n) {
    if (binary) {
      if (!in.read(buf.data(), record)) {
        throw InputError(path + ": truncated: vertex " + std::to_string(n) + " of " +
                         std::to_string(v.count) + " missing");
      }
      int off = 0;
      for (size_t k = 0; k < v.props.size(); ++k) {
        val[k] = Decode(buf.data() + off, v.props[k].type, swap);
        off += v.props[k].size;
      }
    } else {
      if (!std::getline(in, line)) {
        throw InputError(path + ": truncated: vertex " + std::to_string(n) + " of " +
                         std::to_string(v.count) + " missing");
      }
      ++ln;
      std::istringstream ls(line);
      for (size_t k = 0; k < v.props.size(); ++k) {
        std::string tok;
        ls >> tok;
        char* end = nullptr;
        val[k] = std::strtod(tok.c_str(), &end);
        if (tok.empty() || *end != '\0')
          fail(ln, "vertex " + std::to_string(n) + ": bad value '" + tok + "'");
      }
    }
    const Eigen::Vector3d p(val[ix], val[iy], val[iz]);
    if (!p.allFinite())
      throw InputError(path + ": vertex " + std::to_string(n) + ": non-finite coordinate");
    cloud.xyz.push_back(p);
    if (colours) {
      // Colour values outside 0..255 (an ASCII file may say anything) are clamped; a cast
      // of an out-of-range or NaN double to uint8_t would be undefined.
      auto channel = [](double c) {
        return static_cast<uint8_t>(std::isfinite(c) ? std::clamp(c, 0.0, 255.0) : 0.0);
      };
      cloud.rgb.push_back({channel(val[ir]), channel(val[ig]), channel(val[ib])});
    }
    for (size_t k = 0; k < v.props.size(); ++k)
      if (extra[k]) extra[k]->push_back(val[k]);
  }
  return cloud;
}

void WritePly(const std::string& path, const PlyCloud& c) {
  const bool colours = !c.rgb.empty();
  if (colours && c.rgb.size() != c.xyz.size())
    throw InternalError("WritePly: rgb and xyz differ in length");
  for (const auto& [name, values] : c.scalars) {
    if (values.size() != c.xyz.size())
      throw InternalError("WritePly: scalar " + name + " differs in length");
    if (!c.int_scalars.count(name)) continue;
    for (double x : values)
      if (!(x == std::floor(x) && x >= -2147483648.0 && x <= 2147483647.0))
        throw InternalError("WritePly: int scalar " + name + " holds " + std::to_string(x));
  }
  std::ostringstream h;
  h << "ply\nformat binary_little_endian 1.0\n";
  for (const std::string& s : c.comments) h << "comment " << s << "\n";
  h << "element vertex " << c.xyz.size()
    << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (colours) h << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  for (const auto& kv : c.scalars)
    h << "property " << (c.int_scalars.count(kv.first) ? "int " : "float ") << kv.first << "\n";
  h << "end_header\n";
  std::string out = h.str();
  const size_t record = 12 + (colours ? 3 : 0) + 4 * c.scalars.size();
  const size_t start = out.size();
  out.resize(start + record * c.xyz.size());
  char* p = out.data() + start;
  for (size_t i = 0; i < c.xyz.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      const float f = static_cast<float>(c.xyz[i][k]);
      std::memcpy(p, &f, 4);
      p += 4;
    }
    if (colours) {
      std::memcpy(p, c.rgb[i].data(), 3);
      p += 3;
    }
    for (const auto& kv : c.scalars) {
      if (c.int_scalars.count(kv.first)) {
        const int32_t n = static_cast<int32_t>(kv.second[i]);
        std::memcpy(p, &n, 4);
      } else {
        const float f = static_cast<float>(kv.second[i]);
        std::memcpy(p, &f, 4);
      }
      p += 4;
    }
  }
  WriteFileAtomic(path, out);
}

}  // namespace mound::geometry

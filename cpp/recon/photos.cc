#include "recon/photos.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "common/error.h"

namespace mound::recon {
namespace fs = std::filesystem;

namespace {

std::string Kind(const std::string& path, bool* readable) {
  std::ifstream in(path, std::ios::binary);
  unsigned char h[8] = {0};
  *readable = static_cast<bool>(in);
  if (!in) return "unreadable";
  in.read(reinterpret_cast<char*>(h), 8);
  const std::streamsize n = in.gcount();
  if (n >= 3 && h[0] == 0xFF && h[1] == 0xD8 && h[2] == 0xFF) return "jpeg";
  if (n >= 4 && ((h[0] == 'I' && h[1] == 'I' && h[2] == 42 && h[3] == 0) ||
                 (h[0] == 'M' && h[1] == 'M' && h[2] == 0 && h[3] == 42))) {
    return "tiff";
  }
  if (n >= 8 && h[0] == 0x89 && h[1] == 'P' && h[2] == 'N' && h[3] == 'G') return "png";
  return "not_an_image";
}

// Valid UTF-8 (JSON carries names only as text); otherwise the name with each byte of a
// bad sequence written as \xNN, and false.
bool Utf8OrEscaped(std::string* s) {
  std::string out;
  bool ok = true;
  const auto* p = reinterpret_cast<const unsigned char*>(s->data());
  const size_t n = s->size();
  for (size_t i = 0; i < n;) {
    const unsigned char c = p[i];
    size_t len = c < 0x80           ? 1
                 : (c >> 5) == 0x6  ? 2
                 : (c >> 4) == 0xE  ? 3
                 : (c >> 3) == 0x1E ? 4
                                    : 0;
    bool good = len > 0 && i + len <= n;
    for (size_t k = 1; good && k < len; ++k) good = (p[i + k] >> 6) == 0x2;
    if (good) {
      out.append(s->data() + i, len);
      i += len;
    } else {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\x%02X", c);
      out += buf;
      ok = false;
      ++i;
    }
  }
  *s = out;
  return ok;
}

}  // namespace

CardListing ListCard(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(dir + ": not a folder");
  CardListing out;
  const fs::path root(dir);
  fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec);
  if (ec) throw InputError(dir + ": cannot be read (" + ec.message() + ")");
  for (const fs::recursive_directory_iterator end; it != end; it.increment(ec)) {
    if (ec) {
      out.skipped.push_back(it->path().string() + ": " + ec.message());
      ec.clear();
      continue;
    }
    std::error_code e2;
    const fs::file_status st = it->symlink_status(e2);
    if (e2) continue;
    if (fs::is_directory(st)) {
      // Permission denied below is skipped silently by the iterator: say so.
      fs::directory_iterator probe(it->path(), e2);
      if (e2)
        out.skipped.push_back(fs::relative(it->path(), root).generic_string() + ": " +
                              e2.message());
      continue;
    }
    if (fs::is_symlink(st) && fs::is_directory(it->path(), e2)) continue;  // not followed
    if (!fs::is_regular_file(it->path(), e2)) continue;
    CardFile f;
    f.file = fs::relative(it->path(), root, e2).generic_string();
    if (!Utf8OrEscaped(&f.file)) {  // listed, never opened by that (escaped) name
      f.kind = "bad_name";
      out.files.push_back(std::move(f));
      continue;
    }
    bool readable = false;
    f.kind = Kind(it->path().string(), &readable);
    f.bytes = readable ? static_cast<uint64_t>(fs::file_size(it->path(), e2)) : 0;
    if (f.kind == "jpeg" || f.kind == "tiff") {
      f.exif = ReadExif(it->path().string());
      Utf8OrEscaped(&f.exif.make);  // EXIF text is ASCII by the standard, not always so
      Utf8OrEscaped(&f.exif.model);
    }
    out.files.push_back(std::move(f));
  }
  for (std::string& s : out.skipped) Utf8OrEscaped(&s);
  std::sort(out.files.begin(), out.files.end(),
            [](const CardFile& a, const CardFile& b) { return a.file < b.file; });
  return out;
}

}  // namespace mound::recon

#include "common/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/error.h"

namespace mound {

void WriteFileAtomic(const std::string& path, const std::string& contents) {
  // mkstemp: a name no other thread or process is using (two writers of one path no
  // longer share "path.tmp.<pid>"); the last rename wins, each file is whole.
  std::string tmp = path + ".tmp.XXXXXX";
  const int fd = ::mkstemp(tmp.data());
  if (fd < 0) throw InputError(path + ": cannot write (" + std::strerror(errno) + ")");
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::fchmod(fd, 0666 & ~mask);  // mkstemp makes 0600; a result file is as readable as any
  std::FILE* f = ::fdopen(fd, "wb");
  if (f == nullptr) {
    const int err = errno;
    ::close(fd);
    std::remove(tmp.c_str());
    throw InputError(path + ": cannot write (" + std::strerror(err) + ")");
  }
  const size_t written = std::fwrite(contents.data(), 1, contents.size(), f);
  const bool ok = written == contents.size() && std::fflush(f) == 0 && ::fsync(fileno(f)) == 0;
  const bool closed = std::fclose(f) == 0;
  if (!ok || !closed) {
    std::remove(tmp.c_str());
    throw InputError(path + ": write failed (" + std::strerror(errno) + ")");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    std::remove(tmp.c_str());
    throw InputError(path + ": cannot rename into place (" + std::strerror(err) + ")");
  }
}

std::string ReadFile(const std::string& path, size_t max_bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open (" + std::strerror(errno) + ")");
  // In chunks, never more than max_bytes + 1: a device or FIFO that never ends (or a file
  // far larger than any input of ours) is refused instead of filling the memory.
  std::string out;
  std::string chunk(1 << 16, '\0');
  while (in) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    out.append(chunk.data(), static_cast<size_t>(in.gcount()));
    if (out.size() > max_bytes) {
      throw InputError(path + ": larger than " + std::to_string(max_bytes) +
                       " bytes, the most this reader accepts");
    }
  }
  if (in.bad()) throw InputError(path + ": read error");
  return out;
}

std::string ResolveDataFile(const std::string& base, const std::string& rel,
                            const std::string& where) {
  if (rel.empty()) throw InputError(where + ": empty path");
  const std::filesystem::path p(rel);
  const std::string file = p.is_absolute() ? rel : (std::filesystem::path(base) / rel).string();
  std::error_code ec;
  const auto status = std::filesystem::status(file, ec);
  if (ec || !std::filesystem::exists(status)) {
    throw InputError(where + ": " + file + ": no such file");
  }
  if (!std::filesystem::is_regular_file(status)) {
    throw InputError(where + ": " + file + ": not a regular file");
  }
  return file;
}

}  // namespace mound

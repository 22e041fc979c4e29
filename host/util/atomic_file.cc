#include "host/util/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

namespace mfns::host {
namespace {

std::string Errno() { return std::strerror(errno); }

void WriteAll(int fd, const std::uint8_t* data, std::size_t size, const std::string& name) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw UserError(name + ": write failed: " + Errno());
    }
    data += n;
    size -= static_cast<std::size_t>(n);
  }
}

}  // namespace

void WriteFileAtomic(const std::filesystem::path& path, std::span<const std::uint8_t> bytes) {
  const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : ".";
  std::string tmpl = (dir / ("." + path.filename().string() + ".tmp.XXXXXX")).string();
  const int fd = ::mkstemp(tmpl.data());
  if (fd < 0) throw UserError(path.string() + ": cannot create a temp file: " + Errno());
  try {
    WriteAll(fd, bytes.data(), bytes.size(), path.string());
    if (::fchmod(fd, 0644) != 0 || ::fsync(fd) != 0)
      throw UserError(path.string() + ": fsync failed: " + Errno());
    if (::close(fd) != 0) throw UserError(path.string() + ": close failed: " + Errno());
  } catch (...) {
    ::close(fd);
    ::unlink(tmpl.c_str());
    throw;
  }
  if (::rename(tmpl.c_str(), path.c_str()) != 0) {
    const std::string why = Errno();
    ::unlink(tmpl.c_str());
    throw UserError(path.string() + ": rename failed: " + why);
  }
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (dfd >= 0) {
    ::fsync(dfd);  // best effort: the rename is already visible
    ::close(dfd);
  }
}

void WriteFileAtomic(const std::filesystem::path& path, std::string_view text) {
  WriteFileAtomic(path, std::span<const std::uint8_t>(
                            reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

std::string ReadFile(const std::filesystem::path& path, std::size_t max_bytes) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw UserError(path.string() + ": no such file");
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw UserError(path.string() + ": cannot read: " + ec.message());
  if (size > max_bytes)
    throw UserError(path.string() + ": too large (" + std::to_string(size) + " bytes, limit " +
                    std::to_string(max_bytes) + ")");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UserError(path.string() + ": cannot open: " + Errno());
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace mfns::host

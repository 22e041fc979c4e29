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

// A device, FIFO or socket at the path (--out /dev/null, /dev/stdout): written in place, as a
// shell's redirection would; renaming a file over it would replace the node itself (seen: as
// root, `mfns-sim navmatrix --out /dev/null` turned /dev/null into a regular file).
bool WriteInPlaceIfSpecial(const std::filesystem::path& path, std::span<const std::uint8_t> bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || S_ISREG(st.st_mode)) return false;
  const std::string name = OneLine(path.string());
  if (S_ISDIR(st.st_mode)) throw UserError(name + ": is a directory, expected a file");
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) throw UserError(name + ": cannot open: " + Errno());
  try {
    WriteAll(fd, bytes.data(), bytes.size(), name);
  } catch (...) {
    ::close(fd);
    throw;
  }
  if (::close(fd) != 0) throw UserError(name + ": close failed: " + Errno());
  return true;
}

}  // namespace

void WriteFileAtomic(const std::filesystem::path& path, std::span<const std::uint8_t> bytes) {
  if (WriteInPlaceIfSpecial(path, bytes)) return;
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
  const std::string name = OneLine(path.string());  // one-line errors even for a path with a newline
  // O_NONBLOCK: opening a FIFO named like the file must not hang; fstat then says what it is.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENOENT || errno == ENOTDIR) throw UserError(name + ": no such file");
    throw UserError(name + ": cannot open: " + Errno());
  }
  struct FdCloser {
    int fd;
    ~FdCloser() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw UserError(name + ": cannot read: " + Errno());
  if (S_ISDIR(st.st_mode)) throw UserError(name + ": is a directory, expected a file");
  if (!S_ISREG(st.st_mode)) throw UserError(name + ": not a regular file (a FIFO, socket or device)");
  const auto size = static_cast<std::uintmax_t>(st.st_size);
  if (size > max_bytes)
    throw UserError(name + ": too large (" + std::to_string(size) + " bytes, limit " +
                    std::to_string(max_bytes) + ")");
  std::string data(static_cast<std::size_t>(size), '\0');
  std::size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::read(fd, data.data() + done, data.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw UserError(name + ": cannot read: " + Errno());
    if (n == 0) break;  // the file shrank meanwhile
    done += static_cast<std::size_t>(n);
  }
  data.resize(done);
  return data;
}

}  // namespace mfns::host

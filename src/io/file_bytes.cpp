#include "file_bytes.h"

#include <gshell/error.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

namespace gshell::io_detail {

namespace fs = std::filesystem;

void require_file(const std::string& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (!fs::exists(status)) throw InputError(with_file(path, "no such file"));
  if (fs::is_directory(status)) throw InputError(with_file(path, "is a directory, expected a mesh file"));
}

FileBytes::FileBytes(const std::string& path) {
  require_file(path);
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(with_file(path, std::string("cannot open (") + std::strerror(errno) + ")"));
  struct stat st {};
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0) {
    void* map = ::mmap(nullptr, static_cast<std::size_t>(st.st_size), PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
    if (map != MAP_FAILED) {
      ::close(fd);
      map_ = static_cast<const char*>(map);
      size_ = static_cast<std::size_t>(st.st_size);
      return;
    }
  }
  // Read in large blocks until EOF rather than trusting the size (which special files lack).
  char block[1 << 16];
  while (true) {
    const ssize_t got = ::read(fd, block, sizeof block);
    if (got > 0) {
      copy_.append(block, static_cast<std::size_t>(got));
    } else if (got == 0) {
      break;
    } else if (errno != EINTR) {
      const int error = errno;
      ::close(fd);
      throw InputError(with_file(path, std::string("read error (") + std::strerror(error) + ")"));
    }
  }
  ::close(fd);
}

FileBytes::~FileBytes() {
  if (map_) ::munmap(const_cast<char*>(map_), size_);
}

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  if (!ext.empty() && ext[0] == '.') ext.erase(0, 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

} // namespace gshell::io_detail

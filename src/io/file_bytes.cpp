#include "file_bytes.h"

#include <gshell/error.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace gshell::io_detail {

namespace fs = std::filesystem;

std::string read_file_bytes(const std::string& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (!fs::exists(status)) throw InputError(with_file(path, "no such file"));
  if (fs::is_directory(status)) throw InputError(with_file(path, "is a directory, expected a mesh file"));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(with_file(path, std::string("cannot open (") + std::strerror(errno) + ")"));
  // Read in large blocks until EOF rather than trusting file_size (which special files lack).
  std::string bytes;
  const auto size = fs::file_size(path, ec);
  if (!ec) bytes.reserve(size);
  std::string block(1 << 20, '\0');
  while (in.read(block.data(), static_cast<std::streamsize>(block.size())) || in.gcount() > 0)
    bytes.append(block.data(), static_cast<std::size_t>(in.gcount()));
  if (in.bad()) throw InputError(with_file(path, "read error"));
  return bytes;
}

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  if (!ext.empty() && ext[0] == '.') ext.erase(0, 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

} // namespace gshell::io_detail

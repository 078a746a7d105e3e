#include <gshell/io/atomic_file.h>

#include <gshell/error.h>
#include <gshell/io/temporary_outputs.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

namespace gshell {

namespace fs = std::filesystem;

namespace {

// Created with O_EXCL so two writers (threads or processes) never share a temporary, and with
// mode 0666 so the final file gets the user's usual umask permissions (mkstemp would give 0600).
fs::path create_unique_temporary(const fs::path& target) {
  static std::atomic<unsigned> counter{0};
  static const unsigned salt = std::random_device{}();
  const fs::path folder = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::string stem(1, '.');
  stem += target.filename().string();
  stem += ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(salt);
  for (int attempt = 0; attempt < 100; ++attempt) {
    fs::path candidate = folder / (stem + "-" + std::to_string(counter++));
    const int fd = ::open(candidate.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) {
      ::close(fd);
      return candidate;
    }
    if (errno != EEXIST)
      throw InputError(with_file(target.string(), std::string("cannot create file (") + std::strerror(errno) + ")"));
  }
  throw InputError(with_file(target.string(), "cannot create a temporary file next to it"));
}

void remove_quietly(const fs::path& p) {
  std::error_code ignored;
  fs::remove(p, ignored);
}

} // namespace

void check_output_parent(const fs::path& output) {
  const fs::path parent = output.parent_path().empty() ? fs::path(".") : output.parent_path();
  std::error_code ec;
  if (!fs::is_directory(parent, ec))
    throw InputError(with_file(output.string(), fs::exists(parent, ec) ? "parent " + parent.string() + " is not a folder"
                                                                       : std::string("parent folder does not exist")));
}

fs::path output_target(const fs::path& path) {
  // Link by link (a dangling one included: the output is made where it points), at most as deep
  // as the kernel follows links.
  fs::path p = path;
  std::error_code ec;
  for (int depth = 0; depth < 40 && fs::is_symlink(p, ec); ++depth) {
    const fs::path next = fs::read_symlink(p, ec);
    if (ec) return path;
    p = next.is_absolute() ? next : p.parent_path() / next;
  }
  return p;
}

void remove_orphans_of(const fs::path& destination) {
  std::string stem(1, '.'); // built in steps: GCC 12 warns (-Wrestrict, falsely) on "." + name + "."
  stem += destination.filename().string();
  stem += '.';
  std::error_code ec;
  for (fs::directory_iterator it(destination.has_parent_path() ? destination.parent_path() : fs::path("."), ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.compare(0, stem.size(), stem) != 0) continue;
    const std::string rest = name.substr(stem.size()); // "tmp-PID-...", or a folder's "old-PID-..."
    if (rest.compare(0, 4, "tmp-") != 0 && rest.compare(0, 4, "old-") != 0) continue;
    const std::size_t dash = rest.find('-', 4);
    if (dash == std::string::npos || dash == 4) continue;
    const std::string digits = rest.substr(4, dash - 4);
    if (!std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); }) || digits.size() > 9)
      continue;
    const pid_t pid = static_cast<pid_t>(std::stol(digits));
    if (pid == ::getpid() || ::kill(pid, 0) == 0 || errno != ESRCH) continue;
    std::error_code ignored;
    fs::remove_all(it->path(), ignored);
  }
}

void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write, bool binary) {
  if (path.empty()) throw InputError("empty output file name");
  const fs::path target = output_target(path);
  if (fs::is_directory(target)) throw InputError(with_file(path, "is a directory, expected a file name"));
  const fs::path temporary = create_unique_temporary(target);
  const TemporaryOutput registered(temporary);
  try {
    {
      std::ofstream out(temporary, binary ? std::ios::out | std::ios::trunc | std::ios::binary
                                          : std::ios::out | std::ios::trunc);
      if (!out) throw InputError(with_file(path, "cannot open for writing"));
      write(out);
      out.flush();
      if (!out) throw InputError(with_file(path, "write failed (disk full, or past a file size limit?)"));
      out.close();
      if (out.fail()) throw InputError(with_file(path, "write failed when closing the file"));
    }
    std::error_code ec;
    fs::rename(temporary, target, ec);
    if (ec) throw InputError(with_file(path, "cannot move the finished file into place (" + ec.message() + ")"));
  } catch (...) {
    remove_quietly(temporary);
    throw;
  }
}

} // namespace gshell

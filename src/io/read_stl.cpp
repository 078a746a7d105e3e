// STL, ASCII and binary. STL stores three corner points per triangle; identical points (equal
// coordinates, +0 and -0 alike; NaNs with equal bits) become one shared vertex, numbered in order
// of first appearance, so the result is an indexed mesh that validation can check. Binary or
// ASCII is decided by content: an ASCII file starts with "solid" and contains no control bytes
// (some binary files also start with "solid" in their 80-byte header). A binary file must be
// exactly 84 + 50 * (its triangle count) bytes long.
#include "binary_codec.h"
#include "surface_readers.h"
#include "text_scanner.h"

#include <gshell/error.h>

#include <array>
#include <bit>
#include <cctype>
#include <cstdint>
#include <vector>

namespace gshell::io_detail {

namespace {

// Merges equal corner points by exact value, keeping the order of first appearance. An open-
// addressing table of vertex ids (linear probing, keys read back from the vertices themselves):
// a node per vertex, as std::unordered_map allocates, made the weld of millions of corners the
// reader's slowest part, its cost growing faster than the file with cache misses.
class CornerMerger {
public:
  explicit CornerMerger(SurfaceBuilder& b) : b_(b) { rehash(64); }
  void reserve(std::size_t triangles) {
    const std::size_t vertices = triangles / 2 + 3; // a closed surface has about half as many
    if (2 * vertices > slots_.size()) rehash(std::bit_ceil(2 * vertices));
    b_.xyz.reserve(3 * vertices);
    b_.corners.reserve(3 * triangles);
  }
  void add_corner(double x, double y, double z) {
    const Key key{bits(x), bits(y), bits(z)};
    std::size_t s = hash(key) & mask_;
    for (; slots_[s] >= 0; s = (s + 1) & mask_) {
      if (key_of(slots_[s]) == key) {
        b_.corners.push_back(slots_[s]);
        return;
      }
    }
    const int id = b_.num_vertices();
    slots_[s] = id;
    b_.xyz.insert(b_.xyz.end(), {x, y, z});
    b_.corners.push_back(id);
    if (2 * static_cast<std::size_t>(id + 1) > slots_.size()) rehash(2 * slots_.size()); // load <= 1/2
  }

private:
  using Key = std::array<std::uint64_t, 3>;
  static std::size_t hash(const Key& k) {
    std::uint64_t h = 0x9e3779b97f4a7c15ULL;
    for (std::uint64_t v : k) h = (h ^ v) * 0xff51afd7ed558ccdULL, h ^= h >> 32;
    return static_cast<std::size_t>(h);
  }
  /// +0 and -0 are one key; NaNs are keys by their bits.
  static std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v == 0.0 ? 0.0 : v); }
  Key key_of(int id) const {
    const double* p = b_.xyz.data() + 3 * static_cast<std::size_t>(id);
    return {bits(p[0]), bits(p[1]), bits(p[2])};
  }
  void rehash(std::size_t size) { // size: a power of two above twice the vertex count
    slots_.assign(size, -1);
    mask_ = size - 1;
    for (int id = 0; id < b_.num_vertices(); ++id) {
      std::size_t s = hash(key_of(id)) & mask_;
      while (slots_[s] >= 0) s = (s + 1) & mask_;
      slots_[s] = id;
    }
  }

  SurfaceBuilder& b_;
  std::vector<int> slots_; ///< vertex id per slot, -1 where empty
  std::size_t mask_ = 0;
};

bool equals_word(std::string_view token, std::string_view word) {
  if (token.size() != word.size()) return false;
  for (std::size_t i = 0; i < token.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(token[i])) != word[i]) return false;
  return true;
}

bool is_all_text(std::string_view bytes) {
  for (char c : bytes) {
    const auto u = static_cast<unsigned char>(c);
    if ((u < 0x20 && !std::isspace(u)) || u == 0x7f) return false;
  }
  return true;
}

bool starts_with_solid(std::string_view bytes) {
  std::size_t i = 0;
  while (i < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[i]))) ++i;
  return equals_word(bytes.substr(i, 5), "solid");
}

TriMesh read_ascii_stl(const std::string& path, std::string_view bytes) {
  TextScanner s(bytes, path, '\0');
  SurfaceBuilder b;
  CornerMerger merger(b);
  auto expect = [&](std::string_view word) {
    const std::string_view t = s.next_token();
    if (t.empty()) s.fail("unexpected end of file, expected '" + std::string(word) + "' (truncated?)");
    if (!equals_word(t, word))
      s.fail("expected '" + std::string(word) + "', found '" + std::string(t.substr(0, 40)) + "'");
  };
  expect("solid");
  s.skip_rest_of_line(); // the solid's name
  while (true) {
    const std::string_view t = s.next_token();
    if (t.empty()) s.fail("missing 'endsolid' at the end (truncated?)");
    if (equals_word(t, "endsolid")) {
      s.skip_rest_of_line();
      if (s.at_end()) break;
      expect("solid"); // several solids in one file are concatenated
      s.skip_rest_of_line();
      continue;
    }
    if (!equals_word(t, "facet")) s.fail("expected 'facet' or 'endsolid', found '" + std::string(t.substr(0, 40)) + "'");
    std::string_view next = s.next_token();
    if (equals_word(next, "normal")) {
      for (int k = 0; k < 3; ++k) s.next_double("a normal component");
      next = s.next_token();
    }
    if (!equals_word(next, "outer")) s.fail("expected 'outer loop' in a facet");
    expect("loop");
    for (int corner = 0; corner < 3; ++corner) {
      expect("vertex");
      const double x = s.next_double("a vertex coordinate");
      const double y = s.next_double("a vertex coordinate");
      const double z = s.next_double("a vertex coordinate");
      merger.add_corner(x, y, z);
    }
    const std::string_view end_loop = s.next_token();
    if (end_loop.empty()) s.fail("unexpected end of file, expected 'endloop' (truncated?)");
    if (equals_word(end_loop, "vertex")) s.fail("facet with more than 3 vertices (STL stores triangles only)");
    if (!equals_word(end_loop, "endloop")) s.fail("expected 'endloop', found '" + std::string(end_loop.substr(0, 40)) + "'");
    expect("endfacet");
    if (b.corners.size() / 3 >= static_cast<std::size_t>(max_element_count)) s.fail("too many triangles");
  }
  return b.finish();
}

TriMesh read_binary_stl(const std::string& path, std::string_view bytes) {
  constexpr std::size_t header_bytes = 84, triangle_bytes = 50;
  if (bytes.size() < header_bytes)
    throw InputError(with_file(path, "too short for a binary STL (" + std::to_string(bytes.size()) +
                                         " bytes) and not an ASCII STL"));
  const std::uint32_t n = load_value<std::uint32_t>(bytes.data() + 80, false);
  const unsigned long long expected = header_bytes + triangle_bytes * static_cast<unsigned long long>(n);
  if (expected != bytes.size())
    throw InputError(with_file(path, "binary STL header says " + std::to_string(n) + " triangles (" +
                                         std::to_string(expected) + " bytes) but the file has " +
                                         std::to_string(bytes.size()) + " bytes (truncated or corrupt)"));
  if (n >= max_element_count) throw InputError(with_file(path, "too many triangles"));
  SurfaceBuilder b;
  CornerMerger merger(b);
  merger.reserve(n);
  for (std::uint32_t t = 0; t < n; ++t) {
    const char* tri = bytes.data() + header_bytes + triangle_bytes * t + 12; // past the normal
    for (int corner = 0; corner < 3; ++corner) {
      const char* p = tri + 12 * corner;
      merger.add_corner(load_value<float>(p, false), load_value<float>(p + 4, false), load_value<float>(p + 8, false));
    }
  }
  return b.finish();
}

} // namespace

TriMesh read_stl(const std::string& path, std::string_view bytes) {
  if (bytes.empty()) throw InputError(with_file(path, "empty file"));
  const bool text = is_all_text(bytes);
  if (text && starts_with_solid(bytes)) return read_ascii_stl(path, bytes);
  if (text) throw InputError(with_file(path, "not an STL file (an ASCII STL starts with 'solid')"));
  return read_binary_stl(path, bytes);
}

} // namespace gshell::io_detail

#pragma once
// One reader per surface format, each parsing a file already in memory (see file_bytes.h).
#include <gshell/mesh.h>

#include <algorithm>
#include <string>
#include <string_view>
#include <vector>

namespace gshell::io_detail {

/// Names of the data a file holds that a TriMesh does not keep ("vertex colors", "normals", ...),
/// each once, in the order first met, the first kMaxNames of them (a PLY header may list any
/// number of properties): read_mesh's `skipped`.
class SkippedData {
public:
  static constexpr std::size_t kMaxNames = 16;
  explicit SkippedData(std::vector<std::string>* names) : names_(names) {}
  void add(const std::string& name) {
    if (names_ && names_->size() < kMaxNames && std::find(names_->begin(), names_->end(), name) == names_->end())
      names_->push_back(name);
  }

private:
  std::vector<std::string>* names_;
};

/// `warnings` (if not null) receives "PATH: ..." when texture coordinates are dropped because
/// only some faces have them. `skipped` (if not null): as read_mesh's.
TriMesh read_obj(const std::string& path, std::string_view bytes, std::vector<std::string>* warnings = nullptr,
                 std::vector<std::string>* skipped = nullptr);
TriMesh read_off(const std::string& path, std::string_view bytes, std::vector<std::string>* skipped = nullptr);
TriMesh read_ply(const std::string& path, std::string_view bytes, std::vector<std::string>* skipped = nullptr);
TriMesh read_stl(const std::string& path, std::string_view bytes);

/// Flat arrays grown while parsing, turned into a TriMesh at the end.
struct SurfaceBuilder {
  std::vector<double> xyz;   ///< 3 per vertex
  std::vector<int> corners;  ///< 3 per triangle
  std::vector<double> uv;    ///< 2 per texture coordinate
  std::vector<int> uv_corners; ///< 3 per triangle, or empty

  int num_vertices() const { return static_cast<int>(xyz.size() / 3); }
  /// Fan-triangulates polygon (ids[0], ids[k], ids[k+1]): keeps the polygon's orientation and,
  /// for convex polygons, gives valid triangles without looking at positions.
  static void add_fan(std::vector<int>& out, const std::vector<int>& ids);
  TriMesh finish() const;
};

/// Largest vertex or face count we accept: ids are stored as int.
constexpr long long max_element_count = 2'000'000'000LL;

} // namespace gshell::io_detail

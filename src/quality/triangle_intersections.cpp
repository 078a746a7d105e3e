#include <gshell/quality/triangle_intersections.h>

#include "quality/check_mesh_input.h"
#include "quality/embedded_stars.h"
#include "quality/face_pair_search.h"

namespace gshell {
namespace {

using detail::ExactFace;
using Pairs = detail::FacePairs;

bool share_vertex(const ExactFace& a, const ExactFace& b) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (a.id[i] == b.id[j]) return true;
  return false;
}

} // namespace

Pairs self_intersecting_pairs(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  detail::check_triangle_mesh(V, F, "self-intersection test");
  const detail::FaceBvh bvh(V, F, detail::FaceBvh::Use::pairs);
  const std::vector<ExactFace> faces = detail::exact_faces_in_slot_order(V, F, bvh);
  const std::vector<int>& face = bvh.faces_in_leaf_order();
  detail::PairCollector pairs;
  bvh.for_each_overlapping_pair([&](int s, int t) {
    if (!share_vertex(faces[s], faces[t]) && detail::faces_intersect(faces[s], faces[t]))
      pairs.add(std::min(face[s], face[t]), std::max(face[s], face[t]));
  });
  return pairs.sorted();
}

Pairs surface_self_intersections(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  detail::check_triangle_mesh(V, F, "self-intersection test");
  detail::check_distinct_corners(F, "self-intersection test");
  detail::PairCollector pairs;
  const std::vector<char> embedded = detail::embedded_stars(V, F);
  detail::FaceSet(V, F, &embedded).for_each_pair_meeting_beyond_shared([&](int f, int g) { pairs.add(f, g); });
  return pairs.sorted();
}

int count_self_intersections(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  return static_cast<int>(self_intersecting_pairs(V, F).size());
}

Pairs intersecting_pairs_between(const Eigen::MatrixXd& V1, const Eigen::MatrixXi& F1,
                                 const Eigen::MatrixXd& V2, const Eigen::MatrixXi& F2) {
  detail::check_triangle_mesh(V1, F1, "intersection test (first mesh)");
  detail::check_triangle_mesh(V2, F2, "intersection test (second mesh)");
  const detail::FaceBvh bvh1(V1, F1, detail::FaceBvh::Use::pairs);
  const detail::FaceBvh bvh2(V2, F2, detail::FaceBvh::Use::pairs, bvh1.frame());
  const std::vector<ExactFace> faces1 = detail::exact_faces_in_slot_order(V1, F1, bvh1);
  const std::vector<ExactFace> faces2 = detail::exact_faces_in_slot_order(V2, F2, bvh2);
  const std::vector<int>&face1 = bvh1.faces_in_leaf_order(), &face2 = bvh2.faces_in_leaf_order();
  detail::PairCollector pairs;
  bvh1.for_each_overlapping_pair(bvh2, [&](int s1, int s2) {
    if (detail::faces_intersect(faces1[s1], faces2[s2])) pairs.add(face1[s1], face2[s2]);
  });
  return pairs.sorted();
}

int count_intersections_between(const Eigen::MatrixXd& V1, const Eigen::MatrixXi& F1,
                                const Eigen::MatrixXd& V2, const Eigen::MatrixXi& F2) {
  return static_cast<int>(intersecting_pairs_between(V1, F1, V2, F2).size());
}

} // namespace gshell

// Embedded detail carried through valid frames is a one-to-one image of the rest detail (issue 14).
//
// The detail is a wavy triangle surface inside a flat shell, between 0.1 and 0.9 of the thickness
// (a grid 6x finer than the shell's), embedded by embed_points and carried by carry() through
// the frames of a ShellDeformer. The carried detail is the image of the rest detail under the
// piecewise affine map of the shell's tets, which is one-to-one when the frame is valid (no tet
// inverted, no boundary intersection). What "flip" means for a surface embedded in the shell:
// each detail triangle (a, b, c) gets a probe point q = centroid + h n0 (n0 its rest unit normal,
// h = 0.02 of the thickness), embedded like the detail's vertices; the triangle flips when the
// exact orient3d of the carried (a', b', c', q') differs from its rest orientation. For a
// triangle inside one shell tet (a, b, c and q in the same tet: about 37% of them here) the
// carried tet's volume is det F of that shell tet times its rest volume, so this is exactly "the
// carried normal against the carried direction of the rest normal", and a valid frame never flips
// one. A triangle that straddles shell tets is carried as the straight chord between its carried
// corners, which is not the image of the triangle (that bends at the tet faces): where
// neighbouring tets are squeezed differently (a tightly bent, thinned top) the chord can flip in a
// valid frame. Those are counted apart (flipped_chords) and not required to be zero; detail that
// must stay flip-free as drawn should be finer than the shell's tets or split at their faces.
// One-to-one also asks that the carried surface does not pass through itself: no pair of its
// triangles meets except at shared vertices and edges (surface_self_intersections, exact).
//
// Guarded frames (each certified valid independently here) flip no single-tet triangle and keep
// the detail free of self-intersections; the unguarded frames of the same motions (allow_invalid)
// invert tets, and the same checks catch flipped triangles and intersecting pairs there.
#include <gshell/deform/embedding.h>
#include <gshell/deform/shell_deformer.h>
#include <gshell/deform/synthetic_motion.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/quality/triangle_intersections.h>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include "shell_fixtures.h"

#include <cmath>
#include <string>

namespace gshell {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;


struct Detail {
  TriMesh surface;     // rest detail
  Embedding vertices;  // its vertices in the rest shell
  Embedding probes;    // one probe per triangle: centroid + h * rest unit normal
  std::vector<CGAL::Orientation> rest_orientation;
  std::vector<char> single_tet; // per triangle: its vertices and probe lie in one shell tet
};

CGAL::Orientation orientation(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& probes,
                              int f) {
  auto point = [](const Eigen::RowVector3d& p) { return K::Point_3(p[0], p[1], p[2]); };
  return CGAL::orientation(point(V.row(F(f, 0))), point(V.row(F(f, 1))), point(V.row(F(f, 2))), point(probes.row(f)));
}

// A wavy sheet at mid-thickness of the flat shell over [-1, 1]^2 (the plane fixture), between
// 0.3 and 0.7 of the thickness, on a 37 x 37 grid (the shell's is 17 x 17).
Detail embed_detail(const Shell& rest) {
  const double eta = rest.thickness;
  Detail d;
  d.surface = make_plane(96, 0.97);
  Eigen::MatrixXd& V = d.surface.V;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    V(i, 2) = eta * (0.5 + 0.4 * std::sin(3 * V(i, 0)) * std::cos(2 * V(i, 1)));
  const Eigen::MatrixXi& F = d.surface.F;
  Eigen::MatrixXd probes(F.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::RowVector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    probes.row(f) = (a + b + c) / 3 + 0.02 * eta * (b - a).cross(c - a).normalized();
  }
  const Eigen::MatrixXd X = rest.vertices();
  const Eigen::MatrixXi T = ShellDeformer(rest).rest_tets().T;
  d.vertices = embed_points(X, T, V);
  d.probes = embed_points(X, T, probes);
  EXPECT_TRUE(d.vertices.outside.empty());
  EXPECT_TRUE(d.probes.outside.empty());
  int single = 0;
  for (int f = 0; f < F.rows(); ++f) {
    const int t = d.probes.tet(f);
    d.single_tet.push_back(d.vertices.tet(F(f, 0)) == t && d.vertices.tet(F(f, 1)) == t && d.vertices.tet(F(f, 2)) == t);
    single += d.single_tet.back();
    d.rest_orientation.push_back(orientation(V, F, probes, f));
    EXPECT_NE(d.rest_orientation.back(), CGAL::ZERO);
  }
  EXPECT_GT(single, F.rows() / 4);
  return d;
}

struct DetailCheck {
  int flipped = 0;             // single-tet triangles whose probe tet changed orientation (or went flat)
  int flipped_chords = 0;      // the same among triangles that straddle shell tets
  int intersecting_pairs = 0;  // pairs of carried triangles that intersect
};

DetailCheck check_detail(const Detail& d, const Eigen::MatrixXd& X) {
  const Eigen::MatrixXd V = carry(d.vertices, X), probes = carry(d.probes, X);
  DetailCheck out;
  for (int f = 0; f < d.surface.F.rows(); ++f)
    if (orientation(V, d.surface.F, probes, f) != d.rest_orientation[f]) ++(d.single_tet[f] ? out.flipped : out.flipped_chords);
  out.intersecting_pairs = static_cast<int>(surface_self_intersections(V, d.surface.F).size());
  return out;
}

// Moves the plane shell's base through `frames` frames of a bend to `degrees` (band 0.3) with a
// guarded and an unguarded deformer; every guarded frame is certified valid here and carries the
// detail one-to-one. Returns the unguarded frames' detail checks summed.
DetailCheck carry_through(double eta, double band, double degrees, int frames) {
  const Shell rest = test::flat_plane_shell(16, eta);
  const int n = rest.num_base_vertices();
  const Detail detail = embed_detail(rest);
  const DetailCheck at_rest = check_detail(detail, rest.vertices());
  EXPECT_EQ(at_rest.flipped, 0);
  EXPECT_EQ(at_rest.intersecting_pairs, 0);
  const MotionFrame frame = motion_frame(rest.base);
  ShellDeformer guarded(rest), unguarded(rest);
  DeformOptions loose;
  loose.allow_invalid = true;
  DetailCheck unguarded_sum;
  int unguarded_inverted = 0;
  for (int k = 1; k <= frames; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k) + " of a bend to " + std::to_string(degrees) + " degrees");
    const Eigen::MatrixXd base = bend(rest.base, frame, degrees * ramp(k, frames), band);
    const FrameResult r = guarded.solve(base);
    const ShellCertificate c = certify_shell(base, r.top, rest.F);
    EXPECT_TRUE(c.valid());
    EXPECT_EQ(c.inverted_tets, 0);
    EXPECT_EQ(c.base_self_intersections, 0);
    const DetailCheck g = check_detail(detail, guarded.current());
    EXPECT_EQ(g.flipped, 0);
    EXPECT_EQ(g.intersecting_pairs, 0);

    const FrameResult u = unguarded.solve(base, loose);
    Eigen::MatrixXd Xu(2 * n, 3);
    Xu << base, u.top;
    const DetailCheck l = check_detail(detail, Xu);
    unguarded_sum.flipped += l.flipped;

    unguarded_sum.flipped_chords += l.flipped_chords;
    unguarded_sum.intersecting_pairs += l.intersecting_pairs;
    const ShellCertificate cu = certify_shell(base, u.top, rest.F);
    unguarded_inverted += cu.inverted_tets;
  }
  // The unguarded frames invert tets where the detail lies: the checks would see a broken frame.
  EXPECT_GT(unguarded_inverted, 0);
  return unguarded_sum;
}

TEST(EmbeddedDetail, BendTo150DegreesCarriesDetailWithoutFlipsAndTheCheckCatchesUnguardedFlips) {
  // Radius of the band 0.4 / (5 pi / 6) = 0.15 below the thickness 0.3.
  const DetailCheck unguarded = carry_through(0.3, 0.2, 150.0, 6);
  EXPECT_GT(unguarded.flipped, 0);
  EXPECT_GT(unguarded.intersecting_pairs, 0);
}

TEST(EmbeddedDetail, FoldShutCarriesDetailWithoutFlipsAndTheCheckCatchesUnguardedFlips) {
  // Folded shut with radius 0.6 / pi = 0.19: the bases stay 0.38 apart, the tops (0.3) must thin.
  const DetailCheck unguarded = carry_through(0.3, 0.3, 180.0, 8);
  EXPECT_GT(unguarded.flipped, 0);
  EXPECT_GT(unguarded.intersecting_pairs, 0);
}

} // namespace
} // namespace gshell

#pragma once
// Curvature-sensitive ideal prisms (paper §4.1 "Curvature Sensitive Method"; docs/design.md
// "Curvature-sensitive prisms").
#include <gshell/geometry/curvature.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/eigen_abi.h>
#include <Eigen/Core>

namespace gshell {

/// Default clamps of the scale factors. A surface offset by eta grows by 1 + eta * kappa along a
/// principal direction, which reaches 0 (collapse) where eta equals a concave radius of
/// curvature. 0.5 and 2 allow a factor 2 either way (symmetric in log scale): they only bind where
/// eta exceeds half a radius of curvature, i.e. on features narrower than the 2-ring the
/// curvature is averaged over, where the estimate itself is no longer trustworthy, and they keep
/// every ideal tet's aspect ratio within a factor 2 of the normal prism's.
inline constexpr double kDefaultCurvatureSMin = 0.5;
inline constexpr double kDefaultCurvatureSMax = 2.0;

/// \throws InputError naming s_min and s_max unless 0 < s_min <= 1 <= s_max (both finite).
void check_curvature_clamp(double s_min, double s_max);

/// What curvature_prisms had to change to keep the prisms sound.
struct CurvaturePrismStats {
  /// Prisms where 1 + eta * kappa_1 or 1 + eta * kappa_2 fell outside [s_min, s_max].
  int clamped = 0;
  /// Prisms whose anisotropy was reduced: scaling a triangle differently along e_1 and e_2 twists
  /// its side quads, and a strong twist gives one of the prism's 3 tets (the min-index cut,
  /// docs/design.md "Prisms and tets") a tiny or negative volume. There the factors are blended
  /// (geometrically) towards their isotropic mean sqrt(s_1 s_2) just enough for every tet to keep
  /// at least s_min^2 times the volume of the normal prism's tets (eta * area / 3): the bound an
  /// isotropic prism within the clamps always meets (its tets have (1, s, s^2) times that volume).
  int limited = 0;
};

/// Ideal prisms whose top triangle is the base triangle scaled about its centroid, in its plane,
/// by s_i = clamp(1 + eta * kappa_i, s_min, s_max) along the face's principal direction e_i
/// (face_curvature, 2-ring average), then lifted by eta along the face's unit normal (with the
/// anisotropy limit described in CurvaturePrismStats). Same 6m x 3 layout as normal_prisms;
/// equals it where the surface is flat. eta > 0 in model units. `clamped` (if not null) receives
/// the number of prisms where s_1 or s_2 hit a clamp.
/// \throws InputError on a bad clamp (check_curvature_clamp), eta not positive and finite, or V, F
///         that face_curvature rejects.
PrismCorners curvature_prisms(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta,
                              double s_min = kDefaultCurvatureSMin,
                              double s_max = kDefaultCurvatureSMax, int* clamped = nullptr);

/// Same, from curvatures computed already (face_curvature(V, F) or any other estimate), with
/// the full statistics.
/// \throws InputError on a bad clamp, eta not positive and finite, V not n x 3, F not m x 3 with ids
///         in [0, n), or a curvature without one row per face.
PrismCorners curvature_prisms(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                              const FaceCurvature& curvature, double eta, double s_min,
                              double s_max, CurvaturePrismStats* stats = nullptr);

} // namespace gshell

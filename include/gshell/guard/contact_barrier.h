#pragma once
// The contact barrier of one pair (Incremental Potential Contact, Li et al. 2020): on the squared
// distance s of the pair, b(s) = -(s - s_hat)^2 log(s / s_hat) for 0 < s < s_hat = dhat^2 and 0
// beyond. b is C2 at s_hat (b, b' and b'' all vanish there) and grows without bound as s -> 0.
//
// Edge-edge pairs are multiplied by IPC's mollifier m(q) of q = sin^2 of the angle between the
// segments: m = x (2 - x) with x = q / kParallelSin2 below that threshold and 1 above. The
// segments' distance has a kink where they turn parallel (the closest points jump from one end to
// the other); m vanishes to second order there, so m * b is C1 and its Hessian stays bounded.
// Nearly parallel edges are held apart by the point-triangle pairs of the faces around them.
#include <gshell/guard/primitive_distance.h>

namespace gshell {

/// sin^2 of the angle between two segments below which their barrier is mollified (IPC's 1e-3).
inline constexpr double kParallelSin2 = 1e-3;

/// b(s), b'(s), b''(s) for s < s_hat (all 0 for s >= s_hat; b = +infinity at s <= 0).
struct BarrierValue {
  double b = 0, db = 0, d2b = 0;
};
BarrierValue barrier(double s, double s_hat);

/// Barrier of a pair at distance d from each other with dhat the support: b(d^2) (times the
/// mollifier for edge-edge pairs). +infinity when the pair touches (d = 0, mollified or not).
/// `gradient` and `hessian` (optional) receive its exact derivatives by the pair's 12 coordinates
/// (zero beyond dhat; left untouched at contact).
double pair_barrier(PairKind kind, const PairPoints& x, double dhat, Vector12d* gradient = nullptr,
                    Matrix12d* hessian = nullptr);

/// A positive semi-definite Hessian approximation of pair_barrier without an eigen-decomposition:
/// the barrier's second derivative along the distance alone, f''(d) grad d grad d^T with
/// f(d) = b(d^2) (times the mollifier for edge-edge pairs), the curvature of d itself left out
/// (Gauss-Newton). f'' = 4 s b'' + 2 b' > 0 below dhat, so this is PSD by construction; it holds
/// the pair apart along the direction in which it approaches, which is what a step must respect.
/// Zero beyond dhat and at contact.
Matrix12d pair_barrier_gauss_newton(PairKind kind, const PairPoints& x, double dhat);

/// pair_barrier's value when the pair's squared distance s is known (the same bits).
double pair_barrier_energy(PairKind kind, const PairPoints& x, double s, double dhat);

/// Projects a symmetric matrix onto the positive semi-definite cone (negative eigenvalues set to
/// 0), the Hessian approximation of Newton-type solvers. Rows and columns that are zero (points
/// a pair's closest features do not involve) are left out of the eigen-decomposition.
void project_to_psd(Matrix12d& h);

} // namespace gshell

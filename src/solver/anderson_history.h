#pragma once
// Anderson acceleration of a fixed-point map x -> G(x) (type II, as in Peng et al. 2018, "Anderson
// acceleration for geometry optimization and physics simulation"): the next iterate combines the
// last few images so that the combined residual G(x) - x is smallest. Used on the local/global
// map of ShellSolver::solve and of the hierarchical solver's levels; the callers keep a combined
// iterate only if it lowers the energy, so the energy still never rises. `Stored` is the type of
// the differences kept: float halves the history of a generation of millions of vertices (the
// combination is only a candidate, so its rounding cannot spoil the result), double keeps the
// hierarchical solver's iterates as they were.
#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <vector>

namespace gshell::detail {

template <typename Stored = double>
class AndersonHistory {
  using StoredVector = Eigen::Matrix<Stored, Eigen::Dynamic, 1>;

public:
  explicit AndersonHistory(int depth) : depth_(depth), gram_(std::max(depth, 0), std::max(depth, 0)) {}
  void clear() {
    dF_.clear();
    dG_.clear();
    has_last_ = false;
  }
  /// Forgets the last iterate only: the next pair would span a jump that is not a step of the map.
  void restart() { has_last_ = false; }

  /// Records (x, G(x)), both `size` values; returns true and the combined iterate in `out` (`size`
  /// values; may be x, which is read first, but not image) when there is history to combine.
  bool extrapolate(const double* x, const double* image, Eigen::Index size, double* out) {
    if (depth_ <= 0) return false;
    const Eigen::Map<const Eigen::VectorXd> u(x, size), g(image, size);
    f_ = g - u;
    if (has_last_) {
      if (static_cast<int>(dF_.size()) == depth_) { // oldest pair out; its storage is reused
        std::rotate(dF_.begin(), dF_.begin() + 1, dF_.end());
        std::rotate(dG_.begin(), dG_.begin() + 1, dG_.end());
        const int k = depth_ - 1; // the Gram matrix of the kept differences moves up-left
        gram_.topLeftCorner(k, k) = gram_.bottomRightCorner(k, k).eval();
      } else {
        dF_.emplace_back();
        dG_.emplace_back();
      }
      dF_.back().store(f_ - last_f_);
      dG_.back().store(g - last_g_);
      // Only the new difference's products are new: each iteration reads the history once for
      // them and once for the right-hand side, not m^2 / 2 times.
      const int last = static_cast<int>(dF_.size()) - 1;
      for (int i = 0; i <= last; ++i) gram_(i, last) = gram_(last, i) = dF_[i].dot(dF_[last]);
    }
    last_f_ = f_;
    last_g_ = g;
    has_last_ = true;
    if (dF_.empty()) return false;
    const int m = static_cast<int>(dF_.size());
    Eigen::MatrixXd normal = gram_.topLeftCorner(m, m);
    Eigen::VectorXd rhs(m);
    for (int i = 0; i < m; ++i) rhs(i) = dF_[i].dot(f_);
    normal.diagonal().array() += 1e-12 * std::max(1e-300, normal.diagonal().maxCoeff());
    const Eigen::VectorXd gamma = normal.ldlt().solve(rhs);
    Eigen::Map<Eigen::VectorXd> o(out, size);
    o = g;
    for (int i = 0; i < m; ++i) o -= (gamma(i) * dG_[i].scale) * dG_[i].values.template cast<double>();
    return gamma.allFinite();
  }

  /// The same on N x 3 iterates (out is resized to x's shape).
  bool extrapolate(const Eigen::MatrixXd& x, const Eigen::MatrixXd& image, Eigen::MatrixXd& out) {
    out.resize(x.rows(), x.cols());
    return extrapolate(x.data(), image.data(), x.size(), out.data());
  }

private:
  /// A difference of iterates or images, as values * scale. Float keeps 8 digits of each at any
  /// model scale because scale is a power of two near its largest entry (a raw cast overflows
  /// above 3e38 and flushes below 1e-38, and dividing by a power of two rounds nothing). Double
  /// is kept as it is (scale 1).
  struct Difference {
    StoredVector values;
    double scale = 1;
    template <typename Expression>
    void store(const Expression& v) {
      if constexpr (std::is_same_v<Stored, double>) {
        values = v;
      } else {
        const double largest = v.cwiseAbs().maxCoeff();
        int exponent = 0;
        std::frexp(largest, &exponent);
        scale = largest > 0 && std::isfinite(largest) ? std::ldexp(1.0, exponent) : 1.0;
        values = (v / scale).template cast<Stored>();
      }
    }
    double dot(const Difference& other) const {
      return scale * other.scale * values.template cast<double>().dot(other.values.template cast<double>());
    }
    double dot(const Eigen::VectorXd& v) const { return scale * values.template cast<double>().dot(v); }
  };

  int depth_;
  std::vector<Difference> dF_, dG_;
  Eigen::MatrixXd gram_; // dF_i . dF_j of the kept differences
  Eigen::VectorXd f_, last_f_, last_g_;
  bool has_last_ = false;
};

} // namespace gshell::detail

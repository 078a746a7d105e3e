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
  explicit AndersonHistory(int depth) : depth_(depth) {}
  void clear() {
    dF_.clear();
    dG_.clear();
    scale_F_.clear();
    scale_G_.clear();
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
      scale_F_.push_back(store(f_ - last_f_, dF_.back()));
      scale_G_.push_back(store(g - last_g_, dG_.back()));
      if (static_cast<int>(scale_F_.size()) > static_cast<int>(dF_.size())) { // the oldest's scales out
        scale_F_.erase(scale_F_.begin());
        scale_G_.erase(scale_G_.begin());
      }
      // Only the new difference's products are new: each iteration reads the history once for
      // them and once for the right-hand side, not m^2 / 2 times.
      const int last = static_cast<int>(dF_.size()) - 1;
      if (gram_.rows() < depth_) gram_.resize(depth_, depth_);
      for (int i = 0; i <= last; ++i)
        gram_(i, last) = gram_(last, i) =
            scale_F_[i] * scale_F_[last] * dF_[i].template cast<double>().dot(dF_[last].template cast<double>());
    }
    last_f_ = f_;
    last_g_ = g;
    has_last_ = true;
    if (dF_.empty()) return false;
    const int m = static_cast<int>(dF_.size());
    Eigen::MatrixXd normal = gram_.topLeftCorner(m, m);
    Eigen::VectorXd rhs(m);
    for (int i = 0; i < m; ++i) rhs(i) = scale_F_[i] * dF_[i].template cast<double>().dot(f_);
    normal.diagonal().array() += 1e-12 * std::max(1e-300, normal.diagonal().maxCoeff());
    const Eigen::VectorXd gamma = normal.ldlt().solve(rhs);
    Eigen::Map<Eigen::VectorXd> o(out, size);
    o = g;
    for (int i = 0; i < m; ++i) o -= (gamma(i) * scale_G_[i]) * dG_[i].template cast<double>();
    return gamma.allFinite();
  }

  /// The same on N x 3 iterates (out is resized to x's shape).
  bool extrapolate(const Eigen::MatrixXd& x, const Eigen::MatrixXd& image, Eigen::MatrixXd& out) {
    out.resize(x.rows(), x.cols());
    return extrapolate(x.data(), image.data(), x.size(), out.data());
  }

private:
  /// stored <- v / p with p a power of two near max |v| (returned): float keeps 8 digits of each
  /// difference at any model scale (a raw cast overflows above 3e38 and flushes below 1e-38),
  /// and dividing by a power of two rounds nothing. Double is stored as it is (p = 1).
  template <typename Expression>
  static double store(const Expression& v, StoredVector& stored) {
    if constexpr (std::is_same_v<Stored, double>) {
      stored = v;
      return 1.0;
    } else {
      const double largest = v.cwiseAbs().maxCoeff();
      int exponent = 0;
      std::frexp(largest, &exponent);
      const double p = largest > 0 && std::isfinite(largest) ? std::ldexp(1.0, exponent) : 1.0;
      stored = (v / p).template cast<Stored>();
      return p;
    }
  }

  int depth_;
  std::vector<StoredVector> dF_, dG_;
  std::vector<double> scale_F_, scale_G_; // dF_i = scale_F_[i] * dF_[i], the same for dG
  Eigen::MatrixXd gram_;                   // dF_i . dF_j of the kept differences
  Eigen::VectorXd f_, last_f_, last_g_;
  bool has_last_ = false;
};

} // namespace gshell::detail

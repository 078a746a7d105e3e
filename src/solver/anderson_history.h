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
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <vector>

namespace gshell::detail {

template <typename Stored = double>
class AndersonHistory {
  using StoredVector = Eigen::Matrix<Stored, Eigen::Dynamic, 1>;

public:
  /// Iterates of `blocked_from` values or more are passed over in parallel blocks (below).
  explicit AndersonHistory(int depth, Eigen::Index blocked_from = kBlockedFrom)
      : depth_(depth), blocked_from_(blocked_from), gram_(std::max(depth, 0), std::max(depth, 0)) {}
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
    const bool blocked = size >= blocked_from_;
    if (blocked) assign_blocked(f_, size, [&](Eigen::Index k, Eigen::Index n) { return g.segment(k, n) - u.segment(k, n); });
    else f_ = g - u;
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
      if (blocked) {
        dF_.back().store_blocked(f_, last_f_);
        dG_.back().store_blocked(g, last_g_);
      } else {
        dF_.back().store(f_ - last_f_);
        dG_.back().store(g - last_g_);
      }
      // Only the new difference's products are new: each iteration reads the history once for
      // them and once for the right-hand side, not m^2 / 2 times.
      const int last = static_cast<int>(dF_.size()) - 1;
      for (int i = 0; i <= last; ++i) gram_(i, last) = gram_(last, i) = dF_[i].dot(dF_[last], blocked);
    }
    if (blocked) {
      assign_blocked(last_f_, size, [&](Eigen::Index k, Eigen::Index n) { return f_.segment(k, n); });
      assign_blocked(last_g_, size, [&](Eigen::Index k, Eigen::Index n) { return g.segment(k, n); });
    } else {
      last_f_ = f_;
      last_g_ = g;
    }
    has_last_ = true;
    if (dF_.empty()) return false;
    const int m = static_cast<int>(dF_.size());
    Eigen::MatrixXd normal = gram_.topLeftCorner(m, m);
    Eigen::VectorXd rhs(m);
    for (int i = 0; i < m; ++i) rhs(i) = dF_[i].dot(f_, blocked);
    normal.diagonal().array() += 1e-12 * std::max(1e-300, normal.diagonal().maxCoeff());
    const Eigen::VectorXd gamma = normal.ldlt().solve(rhs);
    Eigen::Map<Eigen::VectorXd> o(out, size);
    if (blocked) {
      for_blocks(size, [&](Eigen::Index b, Eigen::Index n) {
        auto ob = o.segment(b, n);
        ob = g.segment(b, n);
        for (int i = 0; i < m; ++i)
          ob -= (gamma(i) * dG_[i].scale) * dG_[i].values.segment(b, n).template cast<double>();
      });
    } else {
      o = g;
      for (int i = 0; i < m; ++i) o -= (gamma(i) * dG_[i].scale) * dG_[i].values.template cast<double>();
    }
    return gamma.allFinite();
  }

  /// The same on N x 3 iterates (out is resized to x's shape).
  bool extrapolate(const Eigen::MatrixXd& x, const Eigen::MatrixXd& image, Eigen::MatrixXd& out) {
    out.resize(x.rows(), x.cols());
    return extrapolate(x.data(), image.data(), x.size(), out.data());
  }

private:
  // From this many values on (a generation of about 350K vertices and more: tens of MB a vector)
  // every pass runs over fixed blocks on all threads, the first touches of fresh history
  // included; sums are taken per block and added in block order, so the result does not depend
  // on the threads' schedule. Smaller iterates (the hierarchy's levels, the frames and poses of
  // shells below that size) keep the serial expressions, and their results as they were.
  static constexpr Eigen::Index kBlockedFrom = Eigen::Index{1} << 20;
  static constexpr Eigen::Index kBlock = Eigen::Index{1} << 16;

  // body(begin, count) over fixed blocks of [0, size), in parallel.
  template <class Body> static void for_blocks(Eigen::Index size, Body&& body) {
    const Eigen::Index blocks = (size + kBlock - 1) / kBlock;
    tbb::parallel_for(Eigen::Index{0}, blocks, [&](Eigen::Index k) {
      const Eigen::Index b = k * kBlock;
      body(b, std::min(kBlock, size - b));
    });
  }
  // term(begin, count) of every block, folded in block order: combine(combine(term0, term1), ...).
  template <class Term, class Combine> static double fold_blocks(Eigen::Index size, Term&& term, Combine&& combine) {
    std::vector<double> part((size + kBlock - 1) / kBlock);
    for_blocks(size, [&](Eigen::Index b, Eigen::Index n) { part[b / kBlock] = term(b, n); });
    double folded = part.empty() ? 0.0 : part[0];
    for (std::size_t i = 1; i < part.size(); ++i) folded = combine(folded, part[i]);
    return folded;
  }
  // out = the blocks block(begin, count) (expressions), out resized but not initialised first:
  // the blocks make the first touches.
  template <class Out, class Block> static void assign_blocked(Out& out, Eigen::Index size, Block&& block) {
    out.resize(size);
    for_blocks(size, [&](Eigen::Index k, Eigen::Index n) { out.segment(k, n) = block(k, n); });
  }
  static double plus(double a, double b) { return a + b; }

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
    /// values * scale = a - b, by blocks.
    template <class A> void store_blocked(const A& a, const Eigen::VectorXd& b) {
      const Eigen::Index size = a.size();
      auto difference = [&](Eigen::Index k, Eigen::Index n) { return a.segment(k, n) - b.segment(k, n); };
      if constexpr (std::is_same_v<Stored, double>) {
        assign_blocked(values, size, difference);
      } else {
        const double largest = fold_blocks(
            size, [&](Eigen::Index k, Eigen::Index n) { return difference(k, n).cwiseAbs().maxCoeff(); },
            [](double x, double y) { return std::max(x, y); });
        int exponent = 0;
        std::frexp(largest, &exponent);
        scale = largest > 0 && std::isfinite(largest) ? std::ldexp(1.0, exponent) : 1.0;
        assign_blocked(values, size,
                       [&](Eigen::Index k, Eigen::Index n) { return (difference(k, n) / scale).template cast<Stored>(); });
      }
    }
    double dot(const Difference& other, bool blocked) const {
      if (!blocked) return scale * other.scale * values.template cast<double>().dot(other.values.template cast<double>());
      return scale * other.scale * fold_blocks(values.size(), [&](Eigen::Index k, Eigen::Index n) {
               return values.segment(k, n).template cast<double>().dot(other.values.segment(k, n).template cast<double>());
             }, plus);
    }
    double dot(const Eigen::VectorXd& v, bool blocked) const {
      if (!blocked) return scale * values.template cast<double>().dot(v);
      return scale * fold_blocks(values.size(), [&](Eigen::Index k, Eigen::Index n) {
               return values.segment(k, n).template cast<double>().dot(v.segment(k, n));
             }, plus);
    }
  };

  int depth_;
  Eigen::Index blocked_from_;
  std::vector<Difference> dF_, dG_;
  Eigen::MatrixXd gram_; // dF_i . dF_j of the kept differences
  Eigen::VectorXd f_, last_f_, last_g_;
  bool has_last_ = false;
};

} // namespace gshell::detail

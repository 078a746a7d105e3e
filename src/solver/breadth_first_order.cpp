#include "solver/breadth_first_order.h"

#include <tbb/parallel_for.h>

namespace gshell::detail {

std::vector<int> breadth_first_order(const RowMajorMatrix& A) {
  const int n = static_cast<int>(A.rows());
  std::vector<char> reached(n, 0);
  std::vector<int> order;
  order.reserve(n);
  for (int seed = 0; seed < n; ++seed) {
    if (reached[seed]) continue;
    reached[seed] = 1;
    order.push_back(seed);
    // order grows while it is read: it is the search's queue.
    for (std::size_t head = order.size() - 1; head < order.size(); ++head)
      for (RowMajorMatrix::InnerIterator it(A, order[head]); it; ++it)
        if (const int c = static_cast<int>(it.index()); !reached[c]) {
          reached[c] = 1;
          order.push_back(c);
        }
  }
  return order;
}

RowMajorMatrix permute_symmetric(const RowMajorMatrix& A, const std::vector<int>& order) {
  const int n = static_cast<int>(A.rows());
  std::vector<int> new_of(n);
  for (int j = 0; j < n; ++j) new_of[order[j]] = j;
  RowMajorMatrix B(n, n);
  int* b_start = B.outerIndexPtr();
  for (int j = 0; j < n; ++j) b_start[j + 1] = b_start[j] + static_cast<int>(A.innerVector(order[j]).nonZeros());
  B.resizeNonZeros(b_start[n]);
  int* b_col = B.innerIndexPtr();
  double* b_val = B.valuePtr();
  tbb::parallel_for(0, n, [&](int j) {
    int* c = b_col + b_start[j];
    double* v = b_val + b_start[j];
    int k = 0;
    for (RowMajorMatrix::InnerIterator it(A, order[j]); it; ++it, ++k) {
      // Insertion into the sorted prefix: rows hold a handful of entries.
      int i = k;
      for (; i > 0 && c[i - 1] > new_of[it.index()]; --i) {
        c[i] = c[i - 1];
        v[i] = v[i - 1];
      }
      c[i] = new_of[it.index()];
      v[i] = it.value();
    }
  });
  return B;
}

} // namespace gshell::detail

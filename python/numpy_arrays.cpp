#include "numpy_arrays.h"

#include <gshell/format_number.h>
#include <gshell/geometry/validate_mesh.h>

#include <climits>
#include <cmath>
#include <sstream>
#include <type_traits>

namespace gshell::python {

void value_error(const std::string& message) { throw py::value_error(message); }

namespace {

std::string shape_text(const py::array& a) {
  std::ostringstream s;
  s << "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) s << (d ? ", " : "") << a.shape(d);
  s << (a.ndim() == 1 ? ",)" : ")");
  return s.str();
}

std::string wanted_shape(int rows, int cols) {
  return "(" + (rows < 0 ? std::string("n") : std::to_string(rows)) + ", " + std::to_string(cols) + ")";
}

std::string dtype_text(const py::array& a) { return py::str(a.dtype()).cast<std::string>(); }

/// np.asarray(object): lists and other array-likes behave as they do everywhere in NumPy.
py::array as_array(const py::handle& object, const char* name) {
  try {
    return py::module_::import("numpy").attr("asarray")(object).cast<py::array>();
  } catch (py::error_already_set& e) {
    // NumPy's own refusals (ragged lists, objects that are no numbers) in one line; anything an
    // array-like's __array__ raised itself (ZeroDivisionError, MemoryError) passes as it was.
    if (!e.matches(PyExc_ValueError) && !e.matches(PyExc_TypeError)) throw;
    value_error(std::string(name) + " is not an array: " + py::str(e.value()).cast<std::string>());
  }
}

void check_shape(const py::array& a, const char* name, const char* kind, int rows, int cols) {
  if (a.ndim() != 2 || a.shape(1) != cols || (rows >= 0 && a.shape(0) != rows))
    value_error(std::string(name) + " must be " + kind + " array of shape " + wanted_shape(rows, cols) +
                "; got shape " + shape_text(a));
}

// One contiguous copy in T. Rows are counted first: gshell indexes them with int, and a copy of
// 2^31 rows takes tens of GB before it could tell. Not array_t::ensure: it clears the error a
// failed conversion raised (MemoryError), which left "error_already_set called while Python error
// indicator not set".
template <class T>
py::array_t<T, py::array::c_style | py::array::forcecast> contiguous(const py::array& a, const char* name) {
  if (a.shape(0) > INT_MAX)
    value_error(std::string(name) + " has too many rows for gshell (" + std::to_string(a.shape(0)) + ")");
  return py::array_t<T, py::array::c_style | py::array::forcecast>(a);
}

template <class Index>
Eigen::MatrixXi index_matrix(const py::array& a, const char* name, int cols, int num_vertices) {
  const auto c = contiguous<Index>(a, name);
  const Eigen::Index n = c.shape(0);
  Eigen::MatrixXi M(n, cols);
  const Index* data = c.data();
  const Index limit = num_vertices >= 0 ? static_cast<Index>(num_vertices) : static_cast<Index>(INT_MAX) + 1;
  for (Eigen::Index i = 0; i < n; ++i)
    for (int j = 0; j < cols; ++j) {
      const Index k = data[i * cols + j];
      bool negative = false;
      if constexpr (std::is_signed_v<Index>) negative = k < 0;
      if (negative || k >= limit)
        value_error(std::string(name) + "[" + std::to_string(i) + ", " + std::to_string(j) + "] = " +
                    std::to_string(k) + " is not a valid index" +
                    (num_vertices >= 0 ? " for " + std::to_string(num_vertices) + " vertices" : std::string()));
      M(i, j) = static_cast<int>(k);
    }
  return M;
}

} // namespace

Eigen::MatrixXd to_matrix(const py::handle& object, const char* name, int cols, int rows, bool finite) {
  const py::array a = as_array(object, name);
  if (a.dtype().kind() != 'f')
    value_error(std::string(name) + " must be a float array (float64) of shape " + wanted_shape(rows, cols) +
                "; got dtype " + dtype_text(a));
  check_shape(a, name, "a float", rows, cols);
  // forcecast + c_style: one contiguous float64 copy whatever the source's dtype and strides.
  const auto c = contiguous<double>(a, name);
  const Eigen::Index n = c.shape(0);
  Eigen::MatrixXd M(n, cols);
  const double* data = c.data();
  for (Eigen::Index i = 0; i < n; ++i)
    for (int j = 0; j < cols; ++j) {
      const double x = data[i * cols + j];
      if (finite && !std::isfinite(x))
        value_error(std::string(name) + "[" + std::to_string(i) + ", " + std::to_string(j) +
                    "] is not finite (" + format_number(x) + ")");
      M(i, j) = x;
    }
  return M;
}

Eigen::MatrixXd to_positions(const py::handle& object, const char* name, int rows) {
  Eigen::MatrixXd M = to_matrix(object, name, 3, rows);
  require_usable_coordinates(M, name);
  return M;
}

Eigen::MatrixXi to_indices(const py::handle& object, const char* name, int cols, int num_vertices, int rows) {
  const py::array a = as_array(object, name);
  const char kind = a.dtype().kind();
  if (kind != 'i' && kind != 'u')
    value_error(std::string(name) + " must be an integer array of shape " + wanted_shape(rows, cols) +
                "; got dtype " + dtype_text(a));
  check_shape(a, name, "an integer", rows, cols);
  // Unsigned arrays are read as uint64: as int64, values from 2^63 up wrapped to negative numbers,
  // and the message showed those instead of what the user wrote.
  return kind == 'u' ? index_matrix<std::uint64_t>(a, name, cols, num_vertices)
                     : index_matrix<std::int64_t>(a, name, cols, num_vertices);
}

py::array_t<double> from_matrix(const Eigen::MatrixXd& M) {
  py::array_t<double> a({M.rows(), M.cols()});
  auto out = a.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < M.rows(); ++i)
    for (Eigen::Index j = 0; j < M.cols(); ++j) out(i, j) = M(i, j);
  return a;
}

py::array_t<double> from_vector(const Eigen::VectorXd& v) {
  py::array_t<double> a(v.size());
  std::copy(v.data(), v.data() + v.size(), a.mutable_data());
  return a;
}

py::array_t<std::int64_t> from_indices(const Eigen::MatrixXi& M) {
  py::array_t<std::int64_t> a({M.rows(), M.cols()});
  auto out = a.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < M.rows(); ++i)
    for (Eigen::Index j = 0; j < M.cols(); ++j) out(i, j) = M(i, j);
  return a;
}

py::array_t<std::int64_t> from_index_vector(const Eigen::VectorXi& v) {
  py::array_t<std::int64_t> a(v.size());
  std::copy(v.data(), v.data() + v.size(), a.mutable_data());
  return a;
}

py::array read_only(py::array a) {
  a.attr("flags").attr("writeable") = false;
  return a;
}

} // namespace gshell::python

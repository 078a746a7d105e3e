#pragma once
// NumPy <-> Eigen for the bindings. Every array that comes from Python is checked here, before the
// library sees it: the library trusts shapes and indices, and a wrong one must become a ValueError
// with a message that names the argument, never a crash of the interpreter.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <cstdint>
#include <string>

namespace gshell::python {

namespace py = pybind11;

/// An array argument: anything np.asarray accepts. Taken as is (so wrong ones reach the checks
/// below and raise ValueError, not pybind11's TypeError) and shown as numpy.ndarray in signatures.
struct ArrayArg {
  py::object object;
  operator py::handle() const { return object; }
};

/// Raises ValueError (through pybind11) with `message`.
[[noreturn]] void value_error(const std::string& message);

/// A real-valued array of shape (rows, cols) (rows = -1: any count), converted to float64.
/// Accepts any floating dtype and anything np.asarray turns into one; rejects integer, bool,
/// complex and object arrays, other shapes, and (when `finite`) NaN or infinite entries.
Eigen::MatrixXd to_matrix(const py::handle& object, const char* name, int cols, int rows = -1,
                          bool finite = true);

/// to_matrix(object, name, 3, rows), held to the coordinates gshell computes with (|x| < 1e50,
/// validate_mesh.h): for positions the library takes without validating them as a surface.
Eigen::MatrixXd to_positions(const py::handle& object, const char* name, int rows = -1);

/// An integer array of shape (rows, cols) (rows = -1: any count) whose entries are indices into
/// `num_vertices` items (num_vertices = -1: only checked to be >= 0 and to fit an int).
Eigen::MatrixXi to_indices(const py::handle& object, const char* name, int cols, int num_vertices, int rows = -1);

/// float64 array (rows, cols), C order, owning a copy.
py::array_t<double> from_matrix(const Eigen::MatrixXd& M);
/// float64 array (n,).
py::array_t<double> from_vector(const Eigen::VectorXd& v);
/// int64 array (rows, cols): NumPy's default integer, so results index other arrays directly.
py::array_t<std::int64_t> from_indices(const Eigen::MatrixXi& M);
/// int64 array (n,).
py::array_t<std::int64_t> from_index_vector(const Eigen::VectorXi& v);

/// Read-only view of an array property: results held by an object must not be changed behind
/// its back (they feed later solves).
py::array read_only(py::array a);

} // namespace gshell::python

namespace pybind11::detail {
template <> struct type_caster<gshell::python::ArrayArg> {
  PYBIND11_TYPE_CASTER(gshell::python::ArrayArg, const_name("numpy.ndarray"));
  bool load(handle source, bool) {
    value.object = reinterpret_borrow<object>(source);
    return true;
  }
};
} // namespace pybind11::detail

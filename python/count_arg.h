#pragma once
// Counts passed from Python (iterations, anderson, steps, levels). pybind11's own int argument
// refuses an int past C++ int's range with "incompatible function arguments" and every overload's
// signature; taking any integer here lets the binding say which argument is out of range instead.
#include <gshell/error.h>

#include <pybind11/pybind11.h>

#include <climits>
#include <string>

namespace gshell::python {

/// An integer argument as Python gave it, not yet narrowed to int.
struct CountArg {
  long long value = 0;
  std::string too_wide; ///< the decimal text of a value beyond long long, else empty

  /// The value as an int. \throws InputError (ValueError in Python) naming `name` when it does not
  /// fit; each option's own range is checked where the options are (options.check()).
  int checked(const char* name) const {
    if (too_wide.empty() && value >= INT_MIN && value <= INT_MAX) return static_cast<int>(value);
    const std::string got = too_wide.empty() ? std::to_string(value) : too_wide;
    throw InputError(std::string(name) + " is out of range (got " + got + "; at most " + std::to_string(INT_MAX) +
                     (got.front() == '-' ? ", and not negative)" : ")"));
  }
};

} // namespace gshell::python

namespace pybind11::detail {

template <> struct type_caster<gshell::python::CountArg> {
  PYBIND11_TYPE_CASTER(gshell::python::CountArg, const_name("int"));

  // As pybind11's int: any object with __index__ (int, bool, numpy integers), never a float.
  bool load(handle src, bool) {
    if (!src || PyFloat_Check(src.ptr())) return false;
    const object index = reinterpret_steal<object>(PyNumber_Index(src.ptr()));
    if (!index) {
      PyErr_Clear();
      return false;
    }
    int overflow = 0;
    value.value = PyLong_AsLongLongAndOverflow(index.ptr(), &overflow);
    value.too_wide = overflow ? str(index).cast<std::string>() : std::string();
    return true;
  }

  static handle cast(const gshell::python::CountArg& count, return_value_policy, handle) {
    return PyLong_FromLongLong(count.value);
  }
};

} // namespace pybind11::detail

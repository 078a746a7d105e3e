#pragma once
// pybind11 hands a method an object whose __init__ (or __setstate__) never ran as raw memory it
// allocates on the spot: `Shell.__new__(Shell).faces` read an uninitialised matrix ("array is too
// big", a bad_alloc, or a hang in embed). The caster below, declared for each bound class before
// its first use, refuses such an object with a TypeError instead.
#include <pybind11/pybind11.h>

#include <string>

#define GSHELL_PYTHON_REQUIRE_INITIALISED(Type, python_name)                                                  \
  namespace pybind11::detail {                                                                               \
  template <> class type_caster<Type> : public type_caster_base<Type> {                                      \
  public:                                                                                                    \
    bool load(handle src, bool convert) {                                                                    \
      if (src && isinstance<Type>(src) &&                                                                    \
          !reinterpret_cast<instance*>(src.ptr())->get_value_and_holder().holder_constructed())              \
        throw type_error(std::string("gshell.") + python_name +                                             \
                         " object is not initialised (made by __new__ without __init__ or __setstate__)");   \
      return type_caster_base<Type>::load(src, convert);                                                     \
    }                                                                                                        \
  };                                                                                                         \
  }

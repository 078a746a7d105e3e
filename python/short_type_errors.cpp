#include "bindings.h"

#include <pybind11/eval.h>

namespace gshell::python {

void shorten_argument_type_errors(pybind11::module_& m) {
  // In Python: the wrapper must see the TypeError pybind11 raises after its overload search, which
  // is in its dispatcher, not in any code of ours. Other TypeErrors pass unchanged.
  pybind11::dict scope;
  scope["module"] = m;
  pybind11::exec(R"py(
import functools

def _shorten(function):
    @functools.wraps(function)
    def call(*args, **kwargs):
        try:
            return function(*args, **kwargs)
        except TypeError as error:
            text = str(error)
            if "incompatible function arguments" not in text and "incompatible constructor arguments" not in text:
                raise
            head = text.split(". The following argument types are supported")[0]
            takes = [line.strip().split(". ", 1)[1] for line in text.splitlines()
                     if line.strip()[:1].isdigit() and ". " in line]
            given = [type(a).__name__ for a in args] + [f"{k}={type(v).__name__}" for k, v in kwargs.items()]
            raise TypeError(f"{head}: it takes {' or '.join(takes)}; given ({', '.join(given)})") from None
    return call

for _name, _value in list(vars(module).items()):
    if type(_value).__name__ == "builtin_function_or_method":
        setattr(module, _name, _shorten(_value))
    elif isinstance(_value, type) and _value.__module__ == module.__name__:
        for _method_name, _method in list(vars(_value).items()):
            if (_method_name == "__init__" or not _method_name.startswith("_")) and \
                    type(_method).__name__ == "instancemethod":
                setattr(_value, _method_name, _shorten(_method))
)py",
                 scope);
}

} // namespace gshell::python

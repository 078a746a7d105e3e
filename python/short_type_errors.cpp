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

def _bool_parameters(function):
    """{position or name: name} of the parameters the signature types as bool (pybind11's bool
    takes None as False: allow_invalid=None would quietly mean False)."""
    doc = (function.__doc__ or "").split("\n", 1)[0]
    if "(" not in doc or doc.startswith("Overloaded"):
        return {}
    inside = doc[doc.index("(") + 1:doc.rfind(") ->") if ") ->" in doc else len(doc)]
    parts, depth, start = [], 0, 0  # split at the commas outside brackets (Optional[...] etc.)
    for i, c in enumerate(inside):
        if c in "[(":
            depth += 1
        elif c in "])":
            depth -= 1
        elif c == "," and depth == 0:
            parts.append(inside[start:i].strip())
            start = i + 1
    parts.append(inside[start:].strip())
    found, positional = {}, True
    for position, part in enumerate(parts):
        if part == "*":  # keyword-only from here
            positional = False
            continue
        name, _, rest = part.partition(":")
        if rest.split("=")[0].strip() == "bool":
            found[name.strip()] = name.strip()
            if positional:
                found[position] = name.strip()
    return found

def _shorten(function, owner=None):
    bools = _bool_parameters(function)
    name = (function.__doc__ or "").split("(", 1)[0].strip() or getattr(function, "__name__", "function")
    label = owner if owner and name == "__init__" else f"{owner}.{name}" if owner else name

    @functools.wraps(function)
    def call(*args, **kwargs):
        for key, value in list(enumerate(args)) + list(kwargs.items()):
            if value is None and key in bools:
                raise TypeError(f"{label}(): {bools[key]} must be True or False, not None")
        try:
            return function(*args, **kwargs)
        except TypeError as error:
            text = str(error)
            # pybind11's own (raised in its dispatcher: no frame below this one), not one a progress
            # callable raised, even with these words in it.
            dispatcher = error.__traceback__ is not None and error.__traceback__.tb_next is None
            if not dispatcher or ("incompatible function arguments" not in text and
                                  "incompatible constructor arguments" not in text):
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
                setattr(_value, _method_name, _shorten(_method, _value.__name__))
)py",
                 scope);
}

} // namespace gshell::python

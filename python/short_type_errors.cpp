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
import inspect
import os

def _parameters(function):
    """[(name, type text, positional, default text or None)] of the parameters pybind11's signature
    line gives; None for a function with several signatures (overloads) or none."""
    doc = (function.__doc__ or "").split("\n", 1)[0]
    if "(" not in doc or doc.startswith("Overloaded"):
        return None
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
    found, positional = [], True
    for part in filter(None, parts):  # "f()" gives one empty part
        if part == "*":  # keyword-only from here
            positional = False
            continue
        name, _, rest = part.partition(":")
        type_text, equals, default = rest.partition("=")
        found.append((name.strip(), type_text.strip(), positional, default.strip() if equals else None))
    return found

class _Shown:
    """A default shown as pybind11's signature line writes it."""
    def __init__(self, text):
        self.text = text
    def __repr__(self):
        return self.text

def _signature(parameters):
    """inspect.Signature of the parsed parameters, or None: functools.wraps points __wrapped__ at the
    builtin, which has no signature inspect can read, so inspect.signature() and help() raised or
    showed (*args, **kwargs)."""
    if parameters is None:
        return None
    try:
        return inspect.Signature([inspect.Parameter(
            name, inspect.Parameter.POSITIONAL_OR_KEYWORD if positional else inspect.Parameter.KEYWORD_ONLY,
            default=inspect.Parameter.empty if default is None else _Shown(default),
            annotation=type_text or inspect.Parameter.empty)
            for name, type_text, positional, default in parameters])
    except (ValueError, TypeError):  # a line this parser misreads: no signature rather than a wrong one
        return None

def _typed(parameters, kind):
    """{position or name: name} of the parameters typed `kind`."""
    found = {}
    for position, (name, type_text, positional, _) in enumerate(parameters or []):
        if type_text == kind:
            found[name] = name
            if positional:
                found[position] = name
    return found

def _is_bool(value):
    kind = type(value)
    return kind is bool or (kind.__module__ == "numpy" and kind.__name__ in ("bool_", "bool"))

def _shown_value(value):
    return repr(value) if value is None or isinstance(value, (int, float)) else type(value).__name__

def _check_path(label, name, value):
    """A path argument pybind11 could not take: the error os.fspath or open() would give, not
    "incompatible function arguments" (which reads as if a str were not accepted)."""
    try:
        path = os.fspath(value)
    except TypeError:
        return  # not path-like at all: the type error stands
    except Exception as error:  # an __fspath__ that raises: its own error
        raise error from None
    if ("\0" if isinstance(path, str) else b"\0") in path:
        raise ValueError(f"{label}(): {name}: embedded null byte") from None

def _shorten(function, owner=None):
    parameters = _parameters(function)
    # pybind11's bool takes None as False and any number by its truth: allow_invalid=None would
    # quietly mean False, and a flag given a count (allow_invalid=2) is more likely a slip.
    bools, paths = _typed(parameters, "bool"), _typed(parameters, "os.PathLike")
    name = (function.__doc__ or "").split("(", 1)[0].strip() or getattr(function, "__name__", "function")
    label = owner if owner and name == "__init__" else f"{owner}.{name}" if owner else name

    @functools.wraps(function)
    def call(*args, **kwargs):
        for key, value in list(enumerate(args)) + list(kwargs.items()):
            if key in bools and not _is_bool(value):
                raise TypeError(f"{label}(): {bools[key]} must be True or False, not {_shown_value(value)}")
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
            for key, value in list(enumerate(args)) + list(kwargs.items()):
                if key in paths:
                    _check_path(label, paths[key], value)
            head = text.split(". The following argument types are supported")[0]
            takes = [line.strip().split(". ", 1)[1] for line in text.splitlines()
                     if line.strip()[:1].isdigit() and ". " in line]
            given = [type(a).__name__ for a in args] + [f"{k}={type(v).__name__}" for k, v in kwargs.items()]
            raise TypeError(f"{head}: it takes {' or '.join(takes)}; given ({', '.join(given)})") from None
    signature = _signature(parameters)
    if signature is not None:
        call.__signature__ = signature
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

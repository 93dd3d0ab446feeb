"""The ``value`` role: a number of fitdf's code, written into a page when it is built.

A page that states a threshold, a prior's constant or a default writes the constant's name
and the build writes its value, so the page cannot drift from the code:

* ``:value:`fitdf.inference.nested.MIN_EFFECTIVE``` -- a module attribute (``400``);
* ``:value:`fitdf.data.cores.STACKING_FACTOR_RANGE[0]``` -- an item of a tuple or mapping
  (``[key][1]``: items of items);
* ``:value:`fitdf.inference.nested.fit_nested(max_evaluations)``` -- a parameter's default;
* ``:value:`...:FORMAT``` -- with a Python format spec after the last colon (``,`` for
  thousands, ``.2f``, ``g``; a percentage, ``.0%``, is written ``95 %`` as the pages
  write it), or ``short`` (``1e4``, ``3e6``, ``1e-3`` for powers of ten
  beyond a thousand or below a hundredth, ``g`` between); without one an integer is
  written as it is and a float by ``g``.

A name that does not resolve is a build error (with ``-W``), as a stale ``:data:``
reference is. :func:`resolve` and :func:`render` are the role without Sphinx, for the
tests.
"""

from __future__ import annotations

import importlib
import inspect
import re

from docutils import nodes

_TARGET = re.compile(
    r"^(?P<path>[A-Za-z_][\w.]*)"
    r"(?:(?P<items>(?:\[[^\]]+\])+)|\((?P<param>\w+)\))?"
    r"(?::(?P<spec>[^:]*))?$"
)


def _attribute(path: str):
    """The object ``path`` names: the longest importable module prefix, then attributes."""
    parts = path.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for name in parts[cut:]:
            obj = getattr(obj, name)
        return obj
    raise ImportError(f"no module in {path!r}")


def resolve(target: str):
    """The value ``target`` names (the role's text without the format spec).

    Raises
    ------
    ValueError
        When ``target`` is not of the role's forms or names nothing.
    """
    match = _TARGET.match(target.strip())
    if not match:
        raise ValueError(f"not a value reference: {target!r}")
    try:
        obj = _attribute(match["path"])
        if match["param"]:
            default = inspect.signature(obj).parameters[match["param"]].default
            if default is inspect.Parameter.empty:
                raise KeyError(match["param"])
            return default
        for item in re.findall(r"\[([^\]]+)\]", match["items"] or ""):
            item = item.strip()
            obj = obj[int(item) if re.fullmatch(r"-?\d+", item) else item.strip("'\"")]
        return obj
    except (ImportError, AttributeError, KeyError, IndexError, TypeError, ValueError) as exc:
        raise ValueError(f"{target!r} names no value of fitdf ({exc!r})") from None


def _short(value) -> str:
    """``1e4``, ``2.5e6``, ``1e-3`` beyond a thousand or below a hundredth; ``g`` between."""
    x = float(value)
    if x != 0 and (abs(x) >= 1e3 or abs(x) < 1e-2):
        mantissa, exponent = f"{x:.6e}".split("e")
        return f"{float(mantissa):g}e{int(exponent)}"
    return f"{x:g}"


def render(text: str) -> str:
    """The text the role writes for ``text`` (``TARGET[:FORMAT]``)."""
    match = _TARGET.match(text.strip())
    if not match:
        raise ValueError(f"not a value reference: {text!r}")
    target = text.strip()
    spec = match["spec"]
    if spec is not None:
        target = target[: -len(spec) - 1]
    value = resolve(target)
    if spec == "short":
        return _short(value)
    if spec and spec.endswith("%"):
        return format(value, spec)[:-1] + " %"
    if spec:
        return format(value, spec)
    if isinstance(value, float):
        return format(value, "g")
    return str(value)


def value_role(name, rawtext, text, lineno, inliner, options=None, content=None):
    try:
        return [nodes.Text(render(text))], []
    except ValueError as exc:
        message = inliner.reporter.error(str(exc), line=lineno)
        problem = inliner.problematic(rawtext, rawtext, message)
        return [problem], [message]


def setup(app):
    app.add_role("value", value_role)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}

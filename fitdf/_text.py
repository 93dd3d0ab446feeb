"""Plain text for a terminal: the line width, table cells, aligned tables and wrapped notes.

Every result's ``text()`` (and every command of :mod:`fitdf.cli`) writes its lines within
:data:`TEXT_WIDTH` columns unless asked for every column. Standard library only.
"""

from __future__ import annotations

import math
import textwrap

__all__ = ["TEXT_WIDTH", "cell", "table_lines", "close_table_lines", "wrap", "cut"]

#: The longest line a command prints by default (its ``--wide`` prints every column).
TEXT_WIDTH = 100


def cell(value, digits: int = 4) -> str:
    """A table cell: floats in ``digits`` significant digits, NaN and None as ``n/a``."""
    if value is None:
        return "n/a"
    if isinstance(value, float) or getattr(getattr(value, "dtype", None), "kind", "") == "f":
        value = float(value)
        return "n/a" if math.isnan(value) else f"{value:.{digits}g}"
    return str(value)


def table_lines(headers, rows, left=(), sep: str = "  ") -> list[str]:
    """Lines of a plain table: ``headers`` over ``rows`` (sequences of str), the columns named
    in ``left`` aligned left, the others right."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(headers)]
    return [
        sep.join(
            c.ljust(w) if h in left else c.rjust(w) for c, w, h in zip(line, widths, headers)
        ).rstrip()
        for line in (headers, *rows)
    ]


def close_table_lines(headers, rows, left=(), width: int = TEXT_WIDTH) -> list[str]:
    """:func:`table_lines`, the columns one space apart when two would pass ``width``."""
    lines = table_lines(headers, rows, left)
    return lines if max(map(len, lines)) <= width else table_lines(headers, rows, left, " ")


def wrap(text: str, width: int = TEXT_WIDTH, indent: str = "", more: str | None = None) -> list:
    """``text`` wrapped at ``width``: the first line indented by ``indent``, the others by
    ``more`` (default: ``indent``). Lines break at spaces only, never inside a file's path
    or a hyphenated word."""
    rest = indent if more is None else more
    lines = textwrap.wrap(
        text, width, initial_indent=indent, subsequent_indent=rest, break_on_hyphens=False
    )
    return lines or [indent]


def cut(line: str, width: int = TEXT_WIDTH) -> str:
    """``line`` cut to ``width`` columns, ending in ``...`` when cut."""
    return line if len(line) <= width else line[: width - 3] + "..."

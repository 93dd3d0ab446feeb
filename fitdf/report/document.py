"""The report's document model: blocks as plain tuples, and the formatting of a table cell.

The blocks are headings, paragraphs, lists, tables, images and collapsible details;
:mod:`fitdf.report.outline` builds the report from them and :mod:`fitdf.report.render`
turns them into Markdown and HTML.
"""

from __future__ import annotations

import re

from fitdf.inference.evidence import SENSITIVITY_FACTORS

__all__ = ["fmt", "slug", "law_names", "law", "H", "P", "UL", "TABLE", "IMG", "DETAILS"]


# ------------------------------------------------------------------ formatting
_NUMBER_WORDS = ("no", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine")


def number_word(n: int) -> str:
    """``3`` -> "three": a count below ten in words, as the report writes it; larger as digits."""
    return _NUMBER_WORDS[n] if 0 <= n < len(_NUMBER_WORDS) else str(n)


_FACTOR_WORDS = {0.5: "halved", 2.0: "doubled", 3.0: "tripled"}


def box_factors(where: bool = False) -> str:
    """How the evidence's prior boxes are changed, from
    :data:`fitdf.inference.evidence.SENSITIVITY_FACTORS`: "halved and doubled"; with
    ``where``, "halved (about the best fit) and doubled (about its centre)"."""
    words = []
    for f in SENSITIVITY_FACTORS:
        word = _FACTOR_WORDS.get(f, f"scaled by {f:g}")
        if where:
            word += " (about the best fit)" if f < 1 else " (about its centre)"
        words.append(word)
    return " and ".join(words) if len(words) < 3 else ", ".join(words[:-1]) + ", and " + words[-1]


def fmt(v, digits=4) -> str:
    """A cell: numbers to ``digits`` significant digits, None as 'n/a', booleans yes/no."""
    if v is None:
        return "n/a"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if v != 0 and (abs(v) >= 1e6 or abs(v) < 1e-3):
            return f"{v:.{digits - 1}e}"
        return f"{v:.{digits}g}"
    return str(v)


def slug(text: str) -> str:
    """GitHub's heading anchor: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[^\w\- ]", "", text.strip().lower().replace("`", ""))
    return text.replace(" ", "-")


def law_names(res: dict) -> dict:
    """Code name -> the law's human name beside its code name (``Title `name```), from the
    ``models`` of a results record (each law's ``title``); a law the record does not
    describe keeps its code name alone. Look names up with ``.get(name, f"`{name}`")``
    or :func:`law`."""
    return {
        m["name"]: f"{m['title']} `{m['name']}`" for m in res.get("models") or [] if m.get("title")
    }


def law(names: dict, name) -> str:
    """``name`` as :func:`law_names` names it (``None`` stays None, for empty cells)."""
    return None if name is None else names.get(name, f"`{name}`")


# ------------------------------------------------------------------ document model
def H(level, text):
    return ("h", level, text)


def P(text):
    return ("p", text)


def UL(items):
    return ("ul", list(items))


def TABLE(header, rows):
    return ("table", list(header), [[fmt(c) for c in r] for r in rows])


def IMG(path, alt):
    return ("img", path, alt)


def DETAILS(summary, blocks):
    return ("details", summary, list(blocks))


def _records_table(records, cols):
    if not records:
        return P("(none)")
    cols = [(k, label) for k, label in cols if any(r.get(k) not in (None, "") for r in records)]
    return TABLE([label for _, label in cols], [[r.get(k) for k, _ in cols] for r in records])

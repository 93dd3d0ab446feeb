"""Sentences from named fields: each sentence the report generates, with the fields of
``results.json`` it is made from, so that a test makes it again from them.

A *rule* is a function registered under a name (its *kind*) with the paths of the fields it
reads (:func:`rule`). It takes those fields' values, and the claim's *subject* (a block key,
an index), and returns its sentence by :func:`say`, or None when it has nothing to say.
:func:`claim` applies a rule to a results record and returns the *claim*, a JSON-ready
record that ``results.json`` keeps beside the sentence::

    {"kind": "block.best", "subject": {"block": "B.2"},
     "fields": {"aicc": "blocks/B.2/ranking_lsq/*/aicc", ...},
     "template": "... {best:law} ... AICc higher by {margin:.1f} ...",
     "values": {"best": "preisach", "margin": 25.9, ...},
     "named_before": [], "text": "..."}

:func:`recompute` makes a claim again from a results record: it reads the fields at their
paths and calls the rule. The test of every sentence is then one loop
(``tests/test_claims.py``): each claim of ``results.json`` is made again and compared, and
its template's own text holds no number (:func:`literal_numbers`), so that every number the
sentence prints is a named value: a field, or a number the rule computes from fields.

Writing a rule::

    @rule("limits.amplitude", ratio="limit_cycles/rows/*/amplitude_ratio")
    def _amplitude(ratio):
        known = [r for r in ratio if r is not None]
        if not known:
            return None
        return say(
            "Predicted over measured amplitude: median {median:.2f} over {n} rows.",
            median=float(np.median(known)),
            n=len(known),
        )

    text = claim("limits.amplitude", results)["text"]

Paths are ``/``-separated keys and list indices of ``results.json``; ``*`` takes every
element of a list (giving a list) or every value of a dict (giving a dict with the same
keys); ``{name}`` is filled from the subject. A path that does not exist reads as None.

Templates are :meth:`str.format` strings with these conversions beside the usual ones: a
law's code name as ``{x:law}`` (its title and code name at its first mention in the
paragraph, the code name alone after it: ``named_before``), a list of them as
``{xs:laws}`` (``a, b and c``), ``{x:code}`` the code name alone, ``{xs:and}`` a list of
strings. A template may be built by the rule (one part per block, say): it is recorded as
made, and the same fields make it again.
"""

from __future__ import annotations

import json
import re
import string
from dataclasses import dataclass, field

from fitdf._json import clean
from fitdf.report.upgrade import upgrade

__all__ = [
    "Said",
    "say",
    "rule",
    "RULES",
    "claim",
    "paragraph",
    "recompute",
    "resolve",
    "text",
    "span",
    "literal_numbers",
    "REFERENCE",
]

#: Numbers a template may print in its own text: references to the thesis's tables, graphs,
#: figures, equations and appendices (``Table B.5``, ``Tables 5.1, 5.2``, ``Graphs 4.1-4.7``).
REFERENCE = re.compile(
    r"\b(?:Tables?|Graphs?|Fig|Figs|eq|eqs|Chapter|Appendix)\.?\s+"
    r"[A-Z]?\.?\d+(?:\.\d+)?(?:\s*(?:-|,|and)\s*[A-Z]?\.?\d+(?:\.\d+)?)*"
    r"|\bB\.\d\b"
)
_NUMBER = re.compile(r"\d+(?:\.\d+)?")


@dataclass(frozen=True)
class Said:
    """A sentence as :func:`say` makes it: its template and the named values filled in."""

    template: str
    values: dict = field(default_factory=dict)


def say(template: str, **values) -> Said:
    """The sentence ``template`` with the named ``values`` (see the module docstring)."""
    return Said(template, clean(values))


@dataclass(frozen=True)
class Rule:
    """A registered rule: ``kind``, the function, and its fields' paths by name."""

    kind: str
    fn: object
    paths: dict


#: Every rule, by kind.
RULES: dict[str, Rule] = {}


def rule(kind: str, **paths):
    """Register the decorated function as the rule ``kind`` reading the fields at ``paths``
    (name -> path, ``{subject}`` placeholders filled from the claim's subject)."""

    def register(fn):
        if kind in RULES and RULES[kind].fn is not fn:
            raise ValueError(f"rule {kind!r} registered twice")
        RULES[kind] = Rule(kind, fn, dict(paths))
        return fn

    return register


def resolve(results: dict, path: str):
    """The value at ``path`` of ``results`` (see the module docstring); None where absent."""

    def walk(node, parts):
        if not parts:
            return node
        head, rest = parts[0], parts[1:]
        if head == "*":
            if isinstance(node, dict):
                return {k: walk(v, rest) for k, v in node.items()}
            if isinstance(node, list):
                return [walk(v, rest) for v in node]
            return None
        if isinstance(node, dict):
            return walk(node[head], rest) if head in node else None
        if isinstance(node, list):
            try:
                return walk(node[int(head)], rest)
            except (ValueError, IndexError):
                return None
        return None

    return walk(results, path.split("/"))


class _Formatter(string.Formatter):
    """:meth:`str.format` with the ``law``, ``laws``, ``code`` and ``and`` conversions."""

    def __init__(self, titles: dict, named: set):
        self.titles, self.named = titles, named

    def law(self, name) -> str:
        if name in self.named or name not in self.titles:
            return f"`{name}`"
        self.named.add(name)
        return f"{self.titles[name]} `{name}`"

    def format_field(self, value, spec):
        if spec == "law":
            return self.law(value)
        if spec == "code":
            return f"`{value}`"
        if spec == "laws":
            return _listed([self.law(v) for v in value])
        if spec == "and":
            return _listed([str(v) for v in value])
        return super().format_field(value, spec)


def _listed(items) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    items = list(items)
    return ", ".join(items[:-1]) + f" and {items[-1]}" if len(items) > 1 else "".join(items)


def _titles(results: dict) -> dict:
    return {m["name"]: m["title"] for m in results.get("models") or [] if m.get("title")}


def _json_value(value):
    """``value`` as ``results.json`` holds it (read back from its JSON text)."""
    return json.loads(json.dumps(clean(value), allow_nan=False))


def claim(kind: str, results: dict, *, named: set | None = None, **subject) -> dict | None:
    """The claim of rule ``kind`` on ``results`` about ``subject`` (a JSON-ready record, see
    the module docstring), or None when the rule says nothing.

    ``named``: the laws already named in full in this paragraph (updated with the ones this
    claim names); None: none. ``results`` of an earlier schema is read as the current one
    (:func:`fitdf.report.upgrade.upgrade`), so the paths are always the current ones."""
    results = upgrade(results)
    r = RULES[kind]
    named = set() if named is None else named
    before = sorted(named)
    paths = {name: p.format(**subject) for name, p in r.paths.items()}
    inputs = {name: _json_value(resolve(results, p)) for name, p in paths.items()}
    said = r.fn(**inputs, **subject)
    if said is None:
        return None
    words = _Formatter(_titles(results), named).vformat(said.template, (), said.values)
    return {
        "kind": kind,
        "subject": _json_value(subject),
        "fields": paths,
        "template": said.template,
        "values": _json_value(said.values),
        "named_before": before,
        "text": words,
    }


def paragraph(results: dict, *specs) -> list[dict]:
    """The claims of ``specs`` (``(kind, subject dict)`` each) in one paragraph: a law is named
    in full at its first mention only. Rules that say nothing are left out."""
    named: set = set()
    out = [claim(kind, results, named=named, **subject) for kind, subject in specs]
    return [c for c in out if c is not None]


def recompute(record: dict, results: dict) -> dict | None:
    """``record`` made again from ``results`` by its rule (what the tests compare it with)."""
    return claim(record["kind"], results, named=set(record["named_before"]), **record["subject"])


def span(low, high, spec: str, low_name: str, high_name: str) -> str:
    """The template of a range of two named values printed with ``spec``: ``{low}-{high}``,
    or ``{low}`` alone when the two print alike."""
    first = "{" + low_name + ":" + spec + "}"
    if format(low, spec) == format(high, spec):
        return first
    return first + "-{" + high_name + ":" + spec + "}"


def text(claims) -> str:
    """The sentences of ``claims`` as one paragraph."""
    return " ".join(c["text"] for c in claims if c)


def literal_numbers(template: str) -> list[str]:
    """The numbers a template prints in its own text (outside its fields), thesis references
    (:data:`REFERENCE`) aside: a template of a claim has none."""
    literal = "".join(part for part, *_ in string.Formatter().parse(template))
    return _NUMBER.findall(REFERENCE.sub("", literal))

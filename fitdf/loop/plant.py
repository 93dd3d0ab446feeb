"""Safe parser for plant transfer functions written as text (no ``eval``, no sympy).

The limit-cycle command takes the linear part of the loop as a string such as the
thesis's plant (section V.6)::

    K/((1+s)(1+0.25s)(1+1.1s))      10/(s*(s+1)*(s+2))      (1+0.5s)/s^3

Grammar (recursive descent; ``*`` may be omitted between factors)::

    expr     := term (("+" | "-") term)*
    term     := unary (("*" | "/" | <implicit *>) unary)*
    unary    := ("+" | "-") unary | power
    power    := atom [("^" | "**") exponent]
    exponent := ["+" | "-"] INTEGER | "(" ["+" | "-"] INTEGER ")"
    atom     := NUMBER | "s" | "K" | "(" expr ")"

``s`` is the Laplace variable and ``K`` the loop gain (replaced by the ``gains`` of a
sweep). Numbers are decimal (``2``, ``0.25``, ``.5``, ``1e-3``). Implicit
multiplication never takes a number as its right operand (``(s+1)2`` and ``2 3`` are
errors, not ``2(s+1)`` and ``6``), so a missing operator is reported, not guessed.

The text is parsed once into a small tree; evaluating the tree for a value of ``K``
gives numerator and denominator polynomials in ``s`` built with numpy (rational
arithmetic, common powers of ``s`` cancelled, denominator made monic). Every mistake
raises :class:`~fitdf.errors.OptionError` with one line naming what and where (1-based
column); limits on length, nesting, exponents and degree keep hostile input harmless.
"""
from __future__ import annotations

import functools
import re
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from fitdf.errors import OptionError

__all__ = ["Plant", "parse_plant", "format_transfer_function", "LoopPlant", "as_loop_plant", "MAX_LENGTH",
           "MAX_DEGREE"]

#: Longest accepted plant text (characters).
MAX_LENGTH = 2000
#: Highest polynomial degree any intermediate result may reach.
MAX_DEGREE = 60
#: Deepest accepted nesting of parentheses / unary signs.
MAX_DEPTH = 60
#: Largest accepted |integer exponent|.
MAX_EXPONENT = 40

_NUMBER = re.compile(r"(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_SYMBOLS = {"s", "K"}


@dataclass(frozen=True)
class _Tok:
    kind: str      # "num", "sym", "op", "end"
    text: str
    col: int       # 1-based column of the first character


def _tokenize(text: str) -> list[_Tok]:
    toks: list[_Tok] = []
    i = 0
    while i < len(text):
        ch = text[i]
        if ch in " \t":
            i += 1
            continue
        m = _NUMBER.match(text, i)
        if m:
            toks.append(_Tok("num", m.group(), i + 1))
            i = m.end()
            continue
        m = _NAME.match(text, i)
        if m:
            word = m.group()
            # "Ks" or "ss" is implicit multiplication of single-letter symbols
            if all(c in _SYMBOLS for c in word):
                toks.extend(_Tok("sym", c, i + 1 + j) for j, c in enumerate(word))
            else:
                raise OptionError(f"plant: unknown name {word!r} at column {i + 1} "
                                  "(use s for the Laplace variable and K for the gain)")
            i = m.end()
            continue
        if text.startswith("**", i):
            toks.append(_Tok("op", "^", i + 1))
            i += 2
            continue
        if ch in "+-*/^()":
            toks.append(_Tok("op", ch, i + 1))
            i += 1
            continue
        raise OptionError(f"plant: unexpected character {ch!r} at column {i + 1}")
    toks.append(_Tok("end", "", len(text) + 1))
    return toks


class _Parser:
    """Recursive descent over the token list; builds tuples ``(kind, ...)``."""

    def __init__(self, toks):
        self.toks = toks
        self.pos = 0
        self.depth = 0

    @property
    def tok(self) -> _Tok:
        return self.toks[self.pos]

    def _take(self) -> _Tok:
        t = self.toks[self.pos]
        self.pos += 1
        return t

    def _fail(self, what: str, tok: _Tok | None = None):
        tok = tok or self.tok
        found = "end of text" if tok.kind == "end" else repr(tok.text)
        raise OptionError(f"plant: {what} at column {tok.col} (found {found})")

    def _enter(self):
        self.depth += 1
        if self.depth > MAX_DEPTH:
            self._fail(f"nesting deeper than {MAX_DEPTH} levels")

    def parse(self):
        if self.tok.kind == "end":
            raise OptionError("plant: empty transfer function (column 1)")
        node = self.expr()
        if self.tok.kind != "end":
            if self.tok.text == ")":
                self._fail("unbalanced ')'")
            self._fail("expected an operator or the end of the text")
        return node

    def expr(self):
        # n-ary lists instead of nested binary nodes: "1+1+...+1" must not recurse
        parts = [("+", self.term(), self.tok.col)]
        while self.tok.kind == "op" and self.tok.text in "+-":
            op = self._take()
            parts.append((op.text, self.term(), op.col))
        return parts[0][1] if len(parts) == 1 and parts[0][0] == "+" else ("sum", parts)

    def term(self):
        parts = [("*", self.unary(), self.tok.col)]
        while True:
            t = self.tok
            if t.kind == "op" and t.text in "*/":
                self._take()
                parts.append((t.text, self.unary(), t.col))
            elif t.kind == "sym" or (t.kind == "op" and t.text == "("):
                parts.append(("*", self.unary(), t.col))   # implicit multiplication
            elif t.kind == "num":
                self._fail("missing operator before a number")
            elif t.kind == "op" and t.text == "^":
                self._fail("a power of a power needs parentheses, as in (s^2)^3")
            else:
                return parts[0][1] if len(parts) == 1 else ("prod", parts)

    def unary(self):
        t = self.tok
        if t.kind == "op" and t.text in "+-":
            self._take()
            self._enter()
            inner = self.unary()
            self.depth -= 1
            return ("neg", inner, t.col) if t.text == "-" else inner
        return self.power()

    def power(self):
        base = self.atom()
        if self.tok.kind == "op" and self.tok.text == "^":
            op = self._take()
            return ("pow", base, self.exponent(), op.col)
        return base

    def exponent(self) -> int:
        paren = self.tok.kind == "op" and self.tok.text == "("
        if paren:
            self._take()
        sign = 1
        if self.tok.kind == "op" and self.tok.text in "+-":
            sign = -1 if self._take().text == "-" else 1
        t = self.tok
        if t.kind != "num" or not t.text.isdigit():
            self._fail("the exponent must be a whole number")
        self._take()
        value = sign * int(t.text[:6]) if len(t.text) <= 6 else MAX_EXPONENT + 1
        if abs(value) > MAX_EXPONENT:
            raise OptionError(f"plant: exponent larger than {MAX_EXPONENT} at column {t.col}")
        if paren:
            if not (self.tok.kind == "op" and self.tok.text == ")"):
                self._fail("expected ')' after the exponent")
            self._take()
        return value

    def atom(self):
        t = self.tok
        if t.kind == "num":
            self._take()
            value = float(t.text)
            if not np.isfinite(value):
                raise OptionError(f"plant: number {t.text!r} out of range at column {t.col}")
            return ("num", value, t.col)
        if t.kind == "sym":
            self._take()
            return ("sym", t.text, t.col)
        if t.kind == "op" and t.text == "(":
            self._take()
            self._enter()
            if self.tok.kind == "op" and self.tok.text == ")":
                self._fail("empty parentheses")
            node = self.expr()
            self.depth -= 1
            if not (self.tok.kind == "op" and self.tok.text == ")"):
                self._fail(f"expected ')' to close the '(' of column {t.col}")
            self._take()
            return node
        self._fail("expected a number, s, K or '('")


# ---------------------------------------------------------------- rational arithmetic
# A value is (num, den): numpy coefficient arrays, highest power first (np.polyval order).

def _trim(p):
    p = np.asarray(p, float)
    nz = np.flatnonzero(p)
    return p[nz[0]:] if nz.size else np.zeros(1)


def _mul(a, b):
    return np.convolve(a, b)


def _add(a, b):
    if a.size < b.size:
        a, b = b, a
    out = a.copy()
    out[a.size - b.size:] += b
    return out


def _check(value, col):
    num, den = value
    if num.size - 1 > MAX_DEGREE or den.size - 1 > MAX_DEGREE:
        raise OptionError(f"plant: polynomial degree above {MAX_DEGREE} at column {col}")
    if not (np.all(np.isfinite(num)) and np.all(np.isfinite(den))):
        raise OptionError(f"plant: coefficients overflow at column {col}")
    # keep magnitudes tame: scale numerator and denominator together
    scale = np.max(np.abs(den))
    if scale > 0 and (scale > 1e100 or scale < 1e-100):
        num, den = num / scale, den / scale
    return _trim(num), _trim(den)


def _evaluate(node, gain: float):
    kind = node[0]
    if kind == "num":
        return np.array([node[1]]), np.ones(1)
    if kind == "sym":
        return (np.array([1.0, 0.0]) if node[1] == "s" else np.array([float(gain)])), np.ones(1)
    if kind == "neg":
        n, d = _evaluate(node[1], gain)
        return -n, d
    if kind == "pow":
        n, d = _evaluate(node[1], gain)
        e = node[2]
        if e < 0:
            if not np.any(n):
                raise OptionError(f"plant: division by zero (zero to a negative power) at column {node[3]}")
            n, d, e = d, n, -e
        pn, pd = np.ones(1), np.ones(1)
        for _ in range(e):    # at most MAX_EXPONENT multiplications, degree checked each time
            pn, pd = _check((_mul(pn, n), _mul(pd, d)), node[3])
        return pn, pd
    if kind == "sum":
        num, den = np.zeros(1), np.ones(1)
        for op, child, col in node[1]:
            n, d = _evaluate(child, gain)
            n = n if op == "+" else -n
            num, den = _check((_add(_mul(num, d), _mul(n, den)), _mul(den, d)), col)
        return num, den
    # "prod"
    num, den = np.ones(1), np.ones(1)
    for op, child, col in node[1]:
        n, d = _evaluate(child, gain)
        if op == "/":
            if not np.any(n):
                raise OptionError(f"plant: division by zero at column {col}")
            n, d = d, n
        num, den = _check((_mul(num, n), _mul(den, d)), col)
    return num, den


def _normalise(num, den):
    """Cancel common powers of ``s``, make the denominator monic."""
    num, den = _trim(num), _trim(den)
    if not np.any(num):
        return np.zeros(1), np.ones(1)
    k = 0
    while k < min(num.size, den.size) - 1 and num[-1 - k] == 0 and den[-1 - k] == 0:
        k += 1
    if k:
        num, den = num[:-k], den[:-k]
    lead = den[0]
    num, den = num / lead, den / lead
    if not (np.all(np.isfinite(num)) and np.all(np.isfinite(den))):
        raise OptionError("plant: coefficients overflow after normalisation")
    return num, den


def _uses_gain(node) -> bool:
    kind = node[0]
    if kind == "sym":
        return node[1] == "K"
    if kind in ("sum", "prod"):
        return any(_uses_gain(child) for _, child, _ in node[1])
    if kind in ("neg", "pow"):
        return _uses_gain(node[1])
    return False


@dataclass(frozen=True)
class Plant:
    """A parsed plant ``G(s; K)``; see :func:`parse_plant`.

    Attributes
    ----------
    text : str
        The text it was parsed from.
    has_gain : bool
        True when the text contains the symbol ``K``.
    linear_in_gain : bool
        True when ``G(s; K) = K G(s; 1)`` (checked numerically), so a gain sweep needs
        one frequency response only.
    """

    text: str
    has_gain: bool
    linear_in_gain: bool
    tree: tuple = field(repr=False, compare=False)

    def polynomials(self, gain: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """Numerator and monic denominator in ``s`` (highest power first) at ``K = gain``."""
        with np.errstate(all="ignore"):
            return _normalise(*_evaluate(self.tree, gain))

    def transfer_function(self, gain: float = 1.0):
        """:class:`control.TransferFunction` at ``K = gain``."""
        import control

        num, den = self.polynomials(gain)
        return control.tf(num, den)

    def frequency_response(self, omega, gain: float = 1.0) -> np.ndarray:
        """``G(j omega; K = gain)`` for an array of angular frequencies (rad/s)."""
        num, den = self.polynomials(gain)
        s = 1j * np.asarray(omega, float)
        with np.errstate(all="ignore"):
            return np.polyval(num, s) / np.polyval(den, s)

    def __str__(self):
        return self.text


@functools.lru_cache(maxsize=256)
def parse_plant(text: str) -> Plant:
    """Parse a transfer function ``G(s)`` (optionally containing the gain ``K``).

    Parameters
    ----------
    text : str
        E.g. ``"K/((1+s)(1+0.25s)(1+1.1s))"`` (the plant of thesis section V.6),
        ``"10/(s*(s+1)*(s+2))"`` or ``"(1+0.5s)/s^3"`` (Fig 5.13's locus (1)).

    Returns
    -------
    Plant

    Raises
    ------
    OptionError
        For any malformed text: one line saying what is wrong and at which column.

    Examples
    --------
    >>> p = parse_plant("K/((1+s)(1+0.25s)(1+1.1s))")
    >>> p.has_gain, p.linear_in_gain
    (True, True)
    >>> num, den = p.polynomials(gain=2.0)
    >>> print(np.round(num, 6), np.round(den, 6))
    [7.272727] [1.       5.909091 8.545455 3.636364]
    >>> parse_plant("1/(s+1")
    Traceback (most recent call last):
    ...
    fitdf.errors.OptionError: plant: expected ')' to close the '(' of column 3 at column 7 (found end of text)
    """
    if not isinstance(text, str):
        raise OptionError(f"plant: expected text, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise OptionError(f"plant: text longer than {MAX_LENGTH} characters (column {MAX_LENGTH + 1})")
    tree = _Parser(_tokenize(text)).parse()
    has_gain = _uses_gain(tree)
    # evaluate once now so that every error surfaces at parse time, not in a solver
    with np.errstate(all="ignore"):
        g1 = _normalise(*_evaluate(tree, 1.0))
        linear = True
        if has_gain:
            g2 = _normalise(*_evaluate(tree, 2.0))
            s = 1j * np.array([0.37, 1.9, 7.3])
            r1 = np.polyval(g1[0], s) / np.polyval(g1[1], s)
            r2 = np.polyval(g2[0], s) / np.polyval(g2[1], s)
            linear = bool(np.all(np.isfinite(r1)) and np.all(np.isfinite(r2))
                          and np.allclose(r2, 2.0 * r1, rtol=1e-9, atol=1e-300))
    return Plant(text=text, has_gain=has_gain, linear_in_gain=linear, tree=tree)


def _format_poly(p) -> str:
    terms = []
    deg = len(p) - 1
    for i, c in enumerate(p):
        if c == 0:
            continue
        power = deg - i
        mono = "" if power == 0 else ("s" if power == 1 else f"s^{power}")
        coef = repr(float(c))
        terms.append(coef + (f"*{mono}" if mono else ""))
    return " + ".join(terms).replace("+ -", "- ") if terms else "0"


def format_transfer_function(num, den) -> str:
    """Text for ``num/den`` that :func:`parse_plant` reads back to the same polynomials.

    Examples
    --------
    >>> format_transfer_function([1.0], [1.0, 3.0, 2.0, 0.0])
    '(1.0)/(1.0*s^3 + 3.0*s^2 + 2.0*s)'
    """
    num, den = (np.atleast_1d(np.asarray(p, float)) for p in (num, den))
    return f"({_format_poly(num)})/({_format_poly(den)})"


# ---------------------------------------------------------------- any plant -> LoopPlant
@dataclass(frozen=True)
class LoopPlant:
    """The linear part ``G(s; K)`` of the loop, however it was given.

    ``G = K G0`` (a gain sweep multiplies one frequency response) unless the text of a
    parsed plant uses ``K`` non-linearly, in which case each gain is evaluated anew.
    """

    label: str
    polys: Callable[[float], tuple]   # gain -> (num, den), highest power first
    has_gain: bool
    linear_in_gain: bool

    def polynomials(self, gain: float = 1.0):
        """``(num, den)`` of ``G`` at loop gain ``gain``."""
        if self.has_gain and not self.linear_in_gain:
            return self.polys(gain)
        num, den = self.polys(1.0)
        return np.asarray(num, float) * gain, np.asarray(den, float)

    def response(self, omega, gains) -> np.ndarray:
        """``G(j omega; K)``: shape ``(len(gains), len(omega))``."""
        omega = np.atleast_1d(np.asarray(omega, float))
        gains = np.atleast_1d(np.asarray(gains, float))
        s = 1j * omega
        with np.errstate(all="ignore"):
            if self.has_gain and not self.linear_in_gain:
                return np.stack([np.polyval(n, s) / np.polyval(d, s) for n, d in map(self.polys, gains)])
            num, den = self.polys(1.0)
            return gains[:, None] * (np.polyval(num, s) / np.polyval(den, s))[None, :]

    def transfer_function(self, gain: float = 1.0):
        import control

        return control.tf(*self.polynomials(gain))

    def corner_frequencies(self) -> np.ndarray:
        num, den = self.polynomials(1.0)
        roots = np.concatenate([np.roots(num) if len(num) > 1 else [], np.roots(den) if len(den) > 1 else []])
        mags = np.abs(roots)
        return mags[mags > 1e-12]


def as_loop_plant(plant, time_scale: float = 1.0) -> LoopPlant:
    """Normalise a plant given as text, ``(num, den)``, a python-control system or a LoopPlant.

    ``time_scale = alpha`` replaces ``G(s)`` by ``G(s / alpha)``: the plant runs
    ``alpha`` times faster (an analog computer's time scaling).
    """
    if isinstance(plant, LoopPlant):
        base = plant
    elif isinstance(plant, str):
        base = _from_plant(parse_plant(plant))
    elif isinstance(plant, Plant):
        base = _from_plant(plant)
    elif isinstance(plant, tuple) and len(plant) == 2:
        num, den = (np.atleast_1d(np.asarray(p, float)) for p in plant)
        _check_polys(num, den)
        base = LoopPlant(label=f"({list(num)})/({list(den)})", polys=lambda g, n=num, d=den: (n, d),
                         has_gain=False, linear_in_gain=True)
    else:
        num, den = _control_polys(plant)
        base = LoopPlant(label=str(plant).strip().replace("\n", " "), polys=lambda g, n=num, d=den: (n, d),
                         has_gain=False, linear_in_gain=True)
    if time_scale == 1.0:
        return base
    if not (np.isfinite(time_scale) and time_scale > 0):
        raise OptionError(f"time_scale must be a positive number, got {time_scale!r}")

    def scaled(g, _b=base, _a=float(time_scale)):
        num, den = _b.polys(g)
        # G(s/a): the coefficient of s^k is divided by a^k (highest power first)
        return (np.asarray(num, float) / _a ** np.arange(len(num) - 1, -1, -1),
                np.asarray(den, float) / _a ** np.arange(len(den) - 1, -1, -1))

    return LoopPlant(label=f"{base.label} at s/{time_scale:g}", polys=scaled, has_gain=base.has_gain,
                     linear_in_gain=base.linear_in_gain)


def _from_plant(p) -> LoopPlant:
    if p.linear_in_gain:
        num, den = p.polynomials(1.0)   # parse-tree evaluation once, not per frequency response
        polys = lambda g, n=num, d=den: (n, d)  # noqa: E731
    else:
        polys = functools.lru_cache(maxsize=256)(p.polynomials)
    return LoopPlant(label=p.text, polys=polys, has_gain=p.has_gain, linear_in_gain=p.linear_in_gain)


def _check_polys(num, den):
    if not (np.all(np.isfinite(num)) and np.all(np.isfinite(den))) or not np.any(den):
        raise OptionError("plant: numerator and denominator must be finite and the denominator non-zero")


def _control_polys(system):
    try:
        import control

        if isinstance(system, control.StateSpace):
            system = control.ss2tf(system)
        if system.ninputs != 1 or system.noutputs != 1:
            raise OptionError("plant: only single-input single-output systems are supported")
        if not system.isctime():
            raise OptionError("plant: a continuous-time system is needed")
        num, den = (np.atleast_1d(np.asarray(p, float)) for p in (system.num[0][0], system.den[0][0]))
    except (AttributeError, TypeError) as exc:
        raise OptionError(f"plant: cannot use a {type(system).__name__}; give text, (num, den) "
                          "or a python-control TransferFunction") from exc
    _check_polys(num, den)
    return num, den

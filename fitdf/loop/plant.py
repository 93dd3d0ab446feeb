"""The linear part ``G(s; K)`` of the loop, and a safe parser for it typed as text.

Grammar of plants such as the thesis's ``K/((1+s)(1+0.25s)(1+1.1s))`` (section V.6)::

    expr  := term (("+" | "-") term)*
    term  := unary (("*" | "/" | <implicit *>) unary)*
    unary := ("+" | "-") unary | atom [("^" | "**") ["+" | "-"] INTEGER]   (exponent may be in parentheses)
    atom  := NUMBER | "s" | "K" | "(" expr ")"

``s`` is the Laplace variable, ``K`` the loop gain; numbers are decimal (``2``, ``.5``, ``1e-3``).
Implicit products never take a number on the right (``(s+1)2`` and ``2 3`` are errors), so a
missing operator is reported, not guessed.

No ``eval``: :mod:`tokenize` splits the text; a pass over the tokens checks the order of operands
and operators, balances parentheses and writes the implicit ``*`` (and ``**`` for ``^``);
:func:`ast.parse` reads that and a whitelist admits only numbers, ``s``, ``K``, ``+ - * /``, signs
and integer powers; the tree is evaluated in :class:`control.TransferFunction` arithmetic, then
common powers of ``s`` are cancelled and the denominator made monic. Mistakes raise a one-line
:class:`~fitdf.errors.OptionError` naming the column. Limits keep hostile input cheap:
``MAX_LENGTH`` bounds all work, ``MAX_DEPTH`` (parentheses and signs) the recursion,
``MAX_EXPONENT`` the multiplications of ``x^n``, ``MAX_OPERATIONS`` their total (a
:class:`~control.TransferFunction` operation costs ~0.1 ms), ``MAX_DEGREE`` every intermediate
polynomial (checked after each operation; numerator and denominator rescaled together to stay finite).
"""

from __future__ import annotations

import ast
import functools
import io
import operator
import re
import tokenize
from collections.abc import Callable
from dataclasses import dataclass, field

import control
import numpy as np

from fitdf.errors import OptionError

__all__ = [
    "MAX_DEGREE",
    "MAX_DEPTH",
    "MAX_EXPONENT",
    "MAX_LENGTH",
    "MAX_OPERATIONS",
    "LoopPlant",
    "Plant",
    "as_loop_plant",
    "format_transfer_function",
    "parse_plant",
]

MAX_LENGTH = 2000  #: longest accepted text (characters)
MAX_DEGREE = 60  #: highest polynomial degree any intermediate result may reach
MAX_DEPTH = 60  #: deepest nesting of parentheses and unary signs
MAX_EXPONENT = 40  #: largest accepted |integer exponent|
MAX_OPERATIONS = 2000  #: most transfer-function operations per evaluation (``x^n`` counts ``|n|``)

_NUMBER = re.compile(r"(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_BAD_CHAR = re.compile(
    r"[^0-9A-Za-z_.+\-*/^() \t]"
)  # also keeps strings, newlines, '#' away from tokenize
_ALLOWED = (
    ast.Expression,
    ast.BinOp,
    ast.UnaryOp,
    ast.Constant,
    ast.Name,
    ast.Load,
    ast.Add,
    ast.Sub,
    ast.Mult,
    ast.Div,
    ast.Pow,
    ast.UAdd,
    ast.USub,
)
_BINARY = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
}
_S = control.TransferFunction(
    [1.0, 0.0], [1.0]
)  # TransferFunction.s, whose int64 coefficients can overflow


def _fail(what: str, col: int, found: str = ""):
    raise OptionError(f"plant: {what} at column {col}" + (f" (found {found})" if found else ""))


def _tokens(text: str) -> list[tuple]:
    """The tokens of ``text``: ``(kind, text, column)``, kind ``"num"``, ``"sym"`` (``s``,
    ``K``, one a letter) or ``"op"``; a character or number the grammar has not is an error."""
    bad = _BAD_CHAR.search(text)
    if bad:
        _fail(f"unexpected character {bad.group()!r}", bad.start() + 1)
    toks, stop = (
        [],
        0,
    )  # (kind "num" | "sym" (s, K) | "op" | "end", text, column); end of the last token
    try:
        for t in tokenize.generate_tokens(io.StringIO(text).readline):
            word, col, stop = t.string, t.start[1] + 1, t.end[1] if t.string.strip() else stop
            if t.type == tokenize.NUMBER:
                if (
                    toks
                    and toks[-1][0] == "num"
                    and not toks[-1][1].strip("0")
                    and toks[-1][2] + len(toks[-1][1]) == col
                ):
                    word, col = (
                        toks[-1][1] + word,
                        toks.pop()[2],
                    )  # Python splits "007" into "00", "7"
                if not _NUMBER.fullmatch(word):
                    _fail(f"malformed number {word!r}", col)
                if not np.isfinite(float(word)):
                    _fail(f"number {word!r} out of range", col)
                toks.append(("num", word, col))
            elif t.type == tokenize.NAME:
                if set(word) - {"s", "K"}:  # "Ks" and "ss" are products of one-letter symbols
                    raise OptionError(
                        f"plant: unknown name {word!r} at column {col} "
                        "(use s for the Laplace variable and K for the gain)"
                    )
                toks.extend(("sym", c, col + j) for j, c in enumerate(word))
            elif t.type == tokenize.OP or (t.type == tokenize.ERRORTOKEN and word.strip()):
                for j, c in enumerate(["^"] if word == "**" else word):  # "//", "." ...: one by one
                    if c not in "+-*/^()":
                        _fail(f"unexpected character {c!r}", col + j)
                    toks.append(("op", c, col + j))
    except tokenize.TokenError as exc:  # at the end inside parentheses: reported below, at the '('
        if text[stop:].strip():  # Python >= 3.12 stops at literals such as "3e+" or "1_"
            _fail(f"cannot read the text ({exc.args[0]})", stop + 1)
    return toks


def _python_source(text: str) -> tuple[str, list[int]]:
    """Tokenize (:func:`_tokens`) and check the order of operands and operators: a Python
    expression with the implicit ``*`` written (and ``**`` for ``^``), and the column in
    ``text`` of each character."""
    toks = _tokens(text)
    if not toks:
        raise OptionError("plant: empty transfer function (column 1)")
    out, cols, stack = [], [], []  # stack: the open '(' and pending unary signs, with their columns
    operand, prev = True, ""
    for kind, word, col in toks + [("end", "", len(text) + 1)]:
        found = "end of text" if kind == "end" else repr(word)
        if len(stack) > MAX_DEPTH:
            _fail(f"nesting deeper than {MAX_DEPTH} levels", col, found)
        if not operand and kind == "num":
            _fail("missing operator before a number", col, found)
        if not operand and (kind == "sym" or word == "("):
            out.append("*")  # implicit product
            cols.append(col)
            operand = True
        if operand:
            if word in ("(", "+", "-"):
                stack.append((word, col))
            elif kind in ("num", "sym"):
                operand = False
            else:
                _fail(
                    "empty parentheses"
                    if word == ")" and prev == "("
                    else "expected a number, s, K or '('",
                    col,
                    found,
                )
        elif word == ")":
            if not stack:
                _fail("unbalanced ')'", col, found)
            stack.pop()
        elif kind == "end" and stack:
            _fail(f"expected ')' to close the '(' of column {stack[-1][1]}", col, found)
        else:
            operand = True  # a binary operator
        while not operand and stack and stack[-1][0] != "(":
            stack.pop()  # an operand ends the unary signs before it
        out.append(
            "**" if word == "^" else str(int(word)) if word.isdigit() else word
        )  # "007" is not Python
        cols.extend([col] * len(out[-1]))
        prev = word
    return "".join(out), cols + [col]


def _parse_tree(src: str, cols: list[int]) -> ast.Expression:
    """``ast.parse`` with a whitelist; binary operators get ``.col``, powers ``.exponent``."""

    def op_col(node):  # the operator is the first of + - * / after the left operand (and its ')')
        gap = src[node.left.end_col_offset : node.right.col_offset]
        return cols[node.left.end_col_offset + next(i for i, c in enumerate(gap) if c in "+-*/")]

    try:
        tree = ast.parse(src, mode="eval")
    except (SyntaxError, RecursionError, MemoryError) as exc:  # not expected after _python_source
        raise OptionError(f"plant: cannot read {src[:40]!r} (column 1)") from exc
    work = 0  # transfer-function operations in one evaluation
    for node in ast.walk(tree):
        if (
            not isinstance(node, _ALLOWED)
            or (isinstance(node, ast.Constant) and type(node.value) not in (int, float))
            or (isinstance(node, ast.Name) and node.id not in ("s", "K"))
        ):
            _fail("unsupported expression", cols[getattr(node, "col_offset", 0)])
        if not isinstance(node, ast.BinOp):
            continue
        node.col, cost = op_col(node), 1
        if isinstance(node.op, ast.Pow):
            e, sign = node.right, 1
            if isinstance(e, ast.UnaryOp):
                e, sign = e.operand, -1 if isinstance(e.op, ast.USub) else 1
            if isinstance(e, ast.BinOp) and isinstance(e.op, ast.Pow):
                _fail("a power of a power needs parentheses, as in (s^2)^3", op_col(e))
            if not (isinstance(e, ast.Constant) and type(e.value) is int):
                _fail("the exponent must be a whole number", cols[e.col_offset])
            if e.value > MAX_EXPONENT:
                _fail(f"exponent larger than {MAX_EXPONENT}", cols[e.col_offset])
            node.exponent, cost = sign * e.value, e.value
        work += cost
        if work > MAX_OPERATIONS:
            _fail(f"more than {MAX_OPERATIONS} operations (x^n counts n)", node.col)
    return tree


def _parts(tf) -> tuple[np.ndarray, np.ndarray]:
    return tf.num_array[0, 0], tf.den_array[0, 0]


def _check(tf, col):
    num, den = _parts(tf)
    if max(num.size, den.size) - 1 > MAX_DEGREE:
        _fail(f"polynomial degree above {MAX_DEGREE}", col)
    if not (np.all(np.isfinite(num)) and np.all(np.isfinite(den))):
        _fail("coefficients overflow", col)
    scale = np.max(np.abs(den))  # keep magnitudes tame: scale numerator and denominator together
    return (
        control.TransferFunction(num / scale, den / scale)
        if scale > 1e100 or 0 < scale < 1e-100
        else tf
    )


def _evaluate(node, gain: float):
    """The tree as a :class:`control.TransferFunction` at ``K = gain``."""
    if isinstance(node, ast.Name) and node.id == "s":
        return _S
    if isinstance(node, (ast.Constant, ast.Name)):  # a number, or K
        return control.TransferFunction(
            [float(gain if isinstance(node, ast.Name) else node.value)], [1.0]
        )
    if isinstance(node, ast.UnaryOp):
        value = _evaluate(node.operand, gain)
        return -value if isinstance(node.op, ast.USub) else value
    chain = []  # loop along the left operands: "1+1+...+1" must not recurse 1000 deep
    while isinstance(node, ast.BinOp):
        chain.append(node)
        node = node.left
    acc = _evaluate(node, gain)
    for b in reversed(chain):
        if isinstance(b.op, ast.Pow):  # |n| multiplications, in order, each checked
            base, acc = acc, control.TransferFunction([1.0], [1.0])
            if b.exponent < 0 and not np.any(_parts(base)[0]):
                _fail("division by zero (zero to a negative power)", b.col)
            base = control.TransferFunction(*_parts(base)[::-1]) if b.exponent < 0 else base
            for _ in range(abs(b.exponent)):
                acc = _check(acc * base, b.col)
            continue
        rhs = _evaluate(b.right, gain)
        if isinstance(b.op, ast.Div) and not np.any(_parts(rhs)[0]):
            _fail("division by zero", b.col)
        acc = _check(_BINARY[type(b.op)](acc, rhs), b.col)
    return acc


def _normalise(num, den):
    """Cancel common powers of ``s``, make the denominator monic."""
    num, den = (np.trim_zeros(np.asarray(p, float), "f") for p in (num, den))
    if not np.any(num):
        return np.zeros(1), np.ones(1)
    k = min(np.flatnonzero(num[::-1])[0], np.flatnonzero(den[::-1])[0], min(num.size, den.size) - 1)
    num, den = num[: num.size - k] / den[0], den[: den.size - k] / den[0]
    if not (np.all(np.isfinite(num)) and np.all(np.isfinite(den))):
        raise OptionError("plant: coefficients overflow after normalisation")
    return num, den


@dataclass(frozen=True)
class Plant:
    """The linear part ``G(s; K)`` of the loop, however it was given (see :func:`as_loop_plant`).

    ``label`` (alias ``text``) is the parsed text or a description; ``polys(gain)`` gives
    ``(num, den)``, highest power first. ``G = K G0`` (a gain sweep scales one frequency
    response) unless the text uses ``K`` (``has_gain``) non-linearly (``linear_in_gain``,
    checked numerically), in which case each gain is evaluated anew.
    """

    label: str
    polys: Callable[[float], tuple] = field(repr=False)
    has_gain: bool = False
    linear_in_gain: bool = True

    text = property(lambda self: self.label)
    __str__ = text.fget

    def polynomials(self, gain: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """``(num, den)`` of ``G`` at loop gain ``gain`` (monic denominator for parsed text)."""
        if self.has_gain and not self.linear_in_gain:
            return self.polys(gain)
        num, den = self.polys(1.0)
        return np.asarray(num, float) * gain, np.asarray(den, float)

    def response(self, omega, gains) -> np.ndarray:
        """``G(j omega; K)``: shape ``(len(gains), len(omega))``."""
        s = 1j * np.atleast_1d(np.asarray(omega, float))
        gains = np.atleast_1d(np.asarray(gains, float))
        with np.errstate(all="ignore"):
            if self.has_gain and not self.linear_in_gain:
                return np.stack(
                    [np.polyval(n, s) / np.polyval(d, s) for n, d in map(self.polys, gains)]
                )
            num, den = self.polys(1.0)
            return gains[:, None] * (np.polyval(num, s) / np.polyval(den, s))[None, :]

    def frequency_response(self, omega, gain: float = 1.0) -> np.ndarray:
        """``G(j omega; K = gain)`` for angular frequencies ``omega`` (rad/s)."""
        return self.response(omega, [gain])[0].reshape(np.shape(omega))

    def transfer_function(self, gain: float = 1.0):
        """:class:`control.TransferFunction` at ``K = gain``."""
        return control.tf(*self.polynomials(gain))

    def corner_frequencies(self) -> np.ndarray:
        num, den = self.polynomials(1.0)
        mags = np.abs(np.concatenate([np.roots(p) if len(p) > 1 else [] for p in (num, den)]))
        return mags[mags > 1e-12]


LoopPlant = Plant  #: former name of the loop's plant, now the same class


@functools.lru_cache(maxsize=256)
def parse_plant(text: str) -> Plant:
    """Parse a transfer function ``G(s)`` (the grammar above), optionally with the gain ``K``.

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
        raise OptionError(
            f"plant: text longer than {MAX_LENGTH} characters (column {MAX_LENGTH + 1})"
        )
    tree = _parse_tree(*_python_source(text))
    has_gain = any(isinstance(n, ast.Name) and n.id == "K" for n in ast.walk(tree))

    def polys(gain):
        with np.errstate(all="ignore"):
            try:
                return _normalise(*_parts(_evaluate(tree.body, gain)))
            except OptionError:
                raise
            except (ValueError, ArithmeticError) as exc:  # e.g. a denominator underflowing to zero
                raise OptionError(f"plant: coefficients out of range at K = {gain:g}") from exc

    g1 = polys(1.0)  # evaluated now, so that every error surfaces at parse time, not in a solver
    linear = True
    if has_gain:
        s = 1j * np.array([0.37, 1.9, 7.3])
        with np.errstate(all="ignore"):
            r1, r2 = (np.polyval(n, s) / np.polyval(d, s) for n, d in (g1, polys(2.0)))
            linear = bool(
                np.all(np.isfinite(r1))
                and np.all(np.isfinite(r2))
                and np.allclose(r2, 2.0 * r1, rtol=1e-9, atol=1e-300)
            )
    return Plant(
        text,
        (lambda g, n=g1[0], d=g1[1]: (n, d)) if linear else functools.lru_cache(maxsize=256)(polys),
        has_gain,
        linear,
    )


def format_transfer_function(num, den) -> str:
    """Text for ``num/den`` that :func:`parse_plant` reads back to the same polynomials.

    >>> format_transfer_function([1.0], [1.0, 3.0, 2.0, 0.0])
    '(1.0)/(1.0*s^3 + 3.0*s^2 + 2.0*s)'
    """

    def poly(p):
        terms = [
            repr(float(c)) + ("" if k == 0 else "*s" if k == 1 else f"*s^{k}")
            for k, c in zip(range(len(p) - 1, -1, -1), p)
            if c != 0
        ]
        return " + ".join(terms).replace("+ -", "- ") if terms else "0"

    return "({})/({})".format(*(poly(np.atleast_1d(np.asarray(p, float))) for p in (num, den)))


def as_loop_plant(plant, time_scale: float = 1.0) -> Plant:
    """A :class:`Plant` from text, ``(num, den)``, a python-control system or a Plant.

    ``time_scale = alpha`` replaces ``G(s)`` by ``G(s / alpha)``: the plant runs
    ``alpha`` times faster (an analog computer's time scaling).
    """
    if isinstance(plant, (Plant, str)):
        base = plant if isinstance(plant, Plant) else parse_plant(plant)
    else:
        try:
            if isinstance(plant, tuple) and len(plant) == 2:
                label, (num, den) = None, plant
            else:
                system = control.ss2tf(plant) if isinstance(plant, control.StateSpace) else plant
                if system.ninputs != 1 or system.noutputs != 1 or not system.isctime():
                    raise OptionError(
                        "plant: a single-input single-output continuous-time system is needed"
                    )
                label, num, den = (
                    str(plant).strip().replace("\n", " "),
                    system.num[0][0],
                    system.den[0][0],
                )
            num, den = (np.atleast_1d(np.asarray(p, float)) for p in (num, den))
        except (AttributeError, TypeError) as exc:
            raise OptionError(
                f"plant: cannot use a {type(plant).__name__}; give text, (num, den) "
                "or a python-control TransferFunction"
            ) from exc
        if not (np.all(np.isfinite(num)) and np.all(np.isfinite(den))) or not np.any(den):
            raise OptionError(
                "plant: numerator and denominator must be finite and the denominator non-zero"
            )
        base = Plant(label or f"({list(num)})/({list(den)})", lambda g, n=num, d=den: (n, d))
    if time_scale == 1.0:
        return base
    if not (np.isfinite(time_scale) and time_scale > 0):
        raise OptionError(f"time_scale must be a positive number, got {time_scale!r}")

    def scaled(g, _b=base, _a=float(time_scale)):  # G(s/a): the coefficient of s^k divided by a^k
        return tuple(
            np.asarray(p, float) / _a ** np.arange(len(p) - 1, -1, -1) for p in _b.polys(g)
        )

    return Plant(f"{base.label} at s/{time_scale:g}", scaled, base.has_gain, base.linear_in_gain)

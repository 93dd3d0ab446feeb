"""Declarative parameter specifications shared by models and measurement chains.

A :class:`ParamSpec` says what a parameter means (unit, thesis equation), where it
may lie (bounds, used as the prior support and by the global optimiser) and where a
fit should start. Models and chains only *declare* parameters; the fitters turn them
into their own coordinates (:meth:`ParamSpec.to_internal`). :class:`Parametrized` is
what a law and a chain share: their declared parameters, listed and described.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from fitdf._text import TEXT_WIDTH, cut, table_lines, wrap

__all__ = [
    "ParamSpec",
    "Parametrized",
    "split_theta",
    "QUANTITIES",
    "PER_TABLE",
    "table_parameter",
    "parameter_base",
    "calibration_gain",
    "current_scaled",
    "DIMENSIONLESS",
    "parameter_lines",
]

#: How a dimensionless parameter's unit is printed (its ``unit`` is ``""`` or ``"1"``).
DIMENSIONLESS = "-"

#: Winding-unit quantities as ``(p, q)``: value = material value x (N A_e)^p x (l_e / N)^q,
#: i.e. the powers of flux linkage per induction and of current per field they carry.
QUANTITIES = {
    "inductance": (1, -1),
    "current": (0, 1),
    "flux_linkage": (1, 0),
    "inductance_per_current": (1, -2),
    "per_current_squared": (0, -2),
    "current_per_hz": (0, 1),
    "current_per_hz2": (0, 1),
    # Bertotti's dynamic fields (fitdf.chains.dynamic): H = k_cl dB/dt is the winding
    # current c_cl e, c_cl = k_cl l_e / (N^2 A_e); H = k_ex |dB/dt|^(1/2) is
    # c_ex |e|^(1/2), c_ex = k_ex (l_e / N) (N A_e)^(-1/2)
    "conductance": (-1, 1),
    "current_per_root_voltage": (-0.5, 1),
}

#: Chain parameters a joint fit gives one copy per table, named ``gain[B.1]``: the
#: tables' calibration factors differ (Tables B.1-B.5 footnotes).
PER_TABLE = ("gain",)


@dataclass(frozen=True)
class ParamSpec:
    """One model or chain parameter.

    Parameters
    ----------
    name : str
        Python identifier used as keyword argument of the model functions.
    default : float
        Starting guess (inside ``bounds``).
    bounds : tuple of float
        Finite ``(lower, upper)``; the prior support of MCMC and the box of the
        global least-squares stage.
    unit : str
        Unit in the winding measurement chain (input in ampere, output in volt-second);
        ``""`` or ``"1"`` for a pure number (printed as :data:`DIMENSIONLESS`).
    description : str
        What the parameter means physically.
    equation : str
        Thesis equation(s) the parameter comes from, e.g. ``"eq 4.2"``.
    log : bool
        True for positive scale parameters spanning decades: optimisers and samplers
        work with ``log10`` of the value.
    quantity : str
        The physical quantity in winding units, a key of :data:`QUANTITIES` (``inductance``,
        ``current``, ``flux_linkage``, ``inductance_per_current``, ...) or ``""``: with a
        core's geometry it maps to a material quantity (permeability, field, induction),
        whose physical limits then set the bounds.
    limits : tuple of float, optional
        The range no value of the parameter can physically leave (a fraction in ``(0, 1)``,
        a width that cannot be negative), when it is narrower than the real line (or, for a
        ``log`` parameter, the positive numbers). A box widened to test the prior's weight
        in the evidence stops there (:meth:`fitdf.inference.problem.FitProblem.with_box_scaled`).
    """

    name: str
    default: float
    bounds: tuple[float, float]
    unit: str = ""
    description: str = ""
    equation: str = ""
    log: bool = False
    quantity: str = ""
    limits: tuple[float, float] | None = None

    def __post_init__(self):
        lo, hi = self.bounds
        if self.limits is not None and not self.limits[0] <= lo < hi <= self.limits[1]:
            raise ValueError(
                f"parameter {self.name!r}: bounds {self.bounds} outside its limits {self.limits}"
            )
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise ValueError(f"parameter {self.name!r}: bounds must be finite with lower < upper")
        if not lo <= self.default <= hi:
            raise ValueError(
                f"parameter {self.name!r}: default {self.default} outside bounds {self.bounds}"
            )
        if self.quantity and self.quantity not in QUANTITIES:
            raise ValueError(f"parameter {self.name!r}: unknown quantity {self.quantity!r}")
        if self.log and lo <= 0:
            raise ValueError(
                f"parameter {self.name!r}: log-scaled parameters need a positive lower bound"
            )

    def internal_limits(self) -> tuple[float, float]:
        """:attr:`limits` in the optimiser's coordinate (infinite where there are none)."""
        lo, hi = self.limits if self.limits is not None else (-np.inf, np.inf)
        if self.log:
            # (the upper limit is above the positive bounds: only the lower one can be 0)
            return (np.log10(lo) if lo > 0 else -np.inf, float(np.log10(hi)))
        return float(lo), float(hi)

    def to_internal(self, value):
        """Map a value to the optimiser's coordinate (log10 for ``log`` parameters)."""
        return np.log10(value) if self.log else np.asarray(value, dtype=float)

    def from_internal(self, internal):
        """Inverse of :meth:`to_internal`."""
        return 10.0 ** np.asarray(internal) if self.log else np.asarray(internal, dtype=float)

    @property
    def unit_label(self) -> str:
        """The unit as printed: :data:`DIMENSIONLESS` (``"-"``) for a pure number."""
        return DIMENSIONLESS if self.unit.strip() in ("", "1") else self.unit

    @property
    def internal_bounds(self) -> tuple[float, float]:
        lo, hi = self.bounds
        return (float(np.log10(lo)), float(np.log10(hi))) if self.log else (lo, hi)


def split_theta(specs: Sequence[ParamSpec], theta) -> dict[str, np.ndarray]:
    """Split ``theta`` of shape ``(..., p)`` into keyword arrays of shape ``(..., 1)``.

    The trailing singleton axis lets each parameter broadcast against an amplitude
    axis, so a batch of parameter vectors (MCMC walkers) evaluates in one call.
    """
    theta = np.asarray(theta, dtype=float)
    if theta.shape[-1] != len(specs):
        raise ValueError(
            f"expected {len(specs)} parameters ({[s.name for s in specs]}), got {theta.shape[-1]}"
        )
    return {s.name: theta[..., i, None] for i, s in enumerate(specs)}


def table_parameter(name: str, table: str) -> str:
    """Name of the copy of per-table parameter ``name`` for ``table`` (``gain[B.1]``)."""
    return f"{name}[{table}]"


def parameter_base(name: str) -> str:
    """``gain[B.1]`` -> ``gain``; other names unchanged."""
    return name.split("[", 1)[0]


def calibration_gain(values) -> float:
    """The calibration gain of fitted ``values``: ``gain``, else the first table's, else 1."""
    if "gain" in values:
        return float(values["gain"])
    return float(next((v for k, v in values.items() if parameter_base(k) == "gain"), 1.0))


def current_scaled(specs: Sequence[ParamSpec], values: dict, scale: float) -> dict:
    """``values`` of the law with parameters ``specs`` after a change of current scale: the law
    whose flux at the current ``i`` is the original's at ``scale * i``.

    Scaling the currents by ``1 / scale`` and the circuit's series resistance by ``scale``
    leaves every measured point unchanged (:mod:`fitdf.data.cores`); a parameter carrying
    ``(l_e / N)^q`` (:data:`QUANTITIES`) scales as ``scale^-q``: a current as ``1 / scale``,
    an inductance as ``scale``, flux linkages not at all. Parameters without a quantity and
    names not in ``specs`` are returned as they are.
    """
    out = dict(values)
    for s in specs:
        if s.name in out and s.quantity:
            out[s.name] = out[s.name] * float(scale) ** -QUANTITIES[s.quantity][1]
    return out


def parameter_lines(params, indent: str = "  ", width: int = TEXT_WIDTH, meanings=True) -> list:
    """Lines of declared parameters: name, unit, bounds, scale and thesis equation, each
    followed (``meanings``) by an indented line of what it means, wrapped at ``width``."""
    rows = [
        [
            p.name,
            p.unit_label,
            f"{p.bounds[0]:g} .. {p.bounds[1]:g}",
            "log" if p.log else "linear",
            p.equation or "-",
        ]
        for p in params
    ]
    headers = ["parameter", "unit", "bounds", "scale", "thesis / source"]
    table = table_lines(headers, rows, left=headers)
    lines = [indent + table[0]]
    for p, line in zip(params, table[1:]):
        lines.append(cut(indent + line, width))
        if meanings:
            text = p.description or "(no description)"
            lines += wrap(text, width, indent + "    ")
    return lines


class Parametrized:
    """What hysteresis laws and measurement chains share: declared parameters, described.

    Subclasses set ``name``, ``title`` and ``params`` (a tuple of :class:`ParamSpec` in
    the order of the ``theta`` vector).
    """

    name: ClassVar[str] = ""
    title: ClassVar[str] = ""
    params: ClassVar[tuple[ParamSpec, ...]] = ()

    @classmethod
    def param_names(cls) -> list[str]:
        return [p.name for p in cls.params]

    @classmethod
    def defaults(cls) -> dict[str, float]:
        return {p.name: p.default for p in cls.params}

    @classmethod
    def describe(cls) -> dict:
        """Plain-dict description for listings and JSON."""
        return {
            "name": cls.name,
            "title": cls.title,
            **cls._extra_description(),
            "parameters": [
                {
                    "name": p.name,
                    "unit": p.unit,
                    "default": p.default,
                    "bounds": list(p.bounds),
                    "description": p.description,
                    "equation": p.equation,
                    "log": p.log,
                }
                for p in cls.params
            ],
        }

    @classmethod
    def _extra_description(cls) -> dict:
        return {}

    @classmethod
    def parameters_text(cls, indent: str = "  ", width: int = TEXT_WIDTH, meanings=True) -> str:
        """The declared parameters as text (:func:`parameter_lines`; "no parameters" if none)."""
        if not cls.params:
            return f"{indent}no parameters"
        return "\n".join(parameter_lines(cls.params, indent, width, meanings))

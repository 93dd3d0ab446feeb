"""Declarative parameter specifications shared by models and measurement chains.

A :class:`ParamSpec` says what a parameter means (unit, thesis equation), where it
may lie (bounds, used as the prior support and by the global optimiser) and where a
fit should start. Models and chains only *declare* parameters; the fitters turn them
into :class:`lmfit.Parameters` with :func:`to_lmfit`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Mapping, Sequence

import numpy as np

__all__ = ["ParamSpec", "to_lmfit", "theta_from_mapping", "split_theta"]


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
        Unit in the winding measurement chain (input in ampere, output in volt-second).
    description : str
        What the parameter means physically.
    equation : str
        Thesis equation(s) the parameter comes from, e.g. ``"eq 4.2"``.
    log : bool
        True for positive scale parameters spanning decades: optimisers and samplers
        work with ``log10`` of the value.
    """

    name: str
    default: float
    bounds: tuple[float, float]
    unit: str = ""
    description: str = ""
    equation: str = ""
    log: bool = False

    def __post_init__(self):
        lo, hi = self.bounds
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise ValueError(f"parameter {self.name!r}: bounds must be finite with lower < upper")
        if not lo <= self.default <= hi:
            raise ValueError(f"parameter {self.name!r}: default {self.default} outside bounds {self.bounds}")
        if self.log and lo <= 0:
            raise ValueError(f"parameter {self.name!r}: log-scaled parameters need a positive lower bound")

    def to_internal(self, value):
        """Map a value to the optimiser's coordinate (log10 for ``log`` parameters)."""
        return np.log10(value) if self.log else np.asarray(value, dtype=float)

    def from_internal(self, internal):
        """Inverse of :meth:`to_internal`."""
        return 10.0 ** np.asarray(internal) if self.log else np.asarray(internal, dtype=float)

    @property
    def internal_bounds(self) -> tuple[float, float]:
        lo, hi = self.bounds
        return (float(np.log10(lo)), float(np.log10(hi))) if self.log else (lo, hi)


def to_lmfit(specs: Iterable[ParamSpec], values: Mapping[str, float] | None = None):
    """Build :class:`lmfit.Parameters` from specs (values default to ``spec.default``)."""
    import lmfit

    params = lmfit.Parameters()
    values = dict(values or {})
    for spec in specs:
        value = float(values.get(spec.name, spec.default))
        value = min(max(value, spec.bounds[0]), spec.bounds[1])
        params.add(spec.name, value=value, min=spec.bounds[0], max=spec.bounds[1])
    return params


def theta_from_mapping(specs: Sequence[ParamSpec], values: Mapping[str, float]) -> np.ndarray:
    """Ordered parameter vector from a name -> value mapping (missing names use defaults)."""
    return np.array([float(values.get(s.name, s.default)) for s in specs])


def split_theta(specs: Sequence[ParamSpec], theta) -> dict[str, np.ndarray]:
    """Split ``theta`` of shape ``(..., p)`` into keyword arrays of shape ``(..., 1)``.

    The trailing singleton axis lets each parameter broadcast against an amplitude
    axis, so a batch of parameter vectors (MCMC walkers) evaluates in one call.
    """
    theta = np.asarray(theta, dtype=float)
    if theta.shape[-1] != len(specs):
        raise ValueError(f"expected {len(specs)} parameters ({[s.name for s in specs]}), got {theta.shape[-1]}")
    return {s.name: theta[..., i, None] for i, s in enumerate(specs)}

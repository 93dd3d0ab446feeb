"""The results of harmonic balance: one limit cycle, and the cycles of a gain sweep.

:class:`LimitCycle` is one solution of ``1 + G(j omega) N(A, omega) = 0``;
:class:`LimitCycleResponse` holds every solution of a sweep of the loop gain, the
critical gain, and the plant and describing function needed to plot them. Both are
built by :func:`fitdf.loop.harmonic.limit_cycles`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from fitdf._json import clean
from fitdf.loop.plant import LoopPlant
from fitdf.loop.presentation import response_text

__all__ = ["LimitCycle", "LimitCycleResponse"]


@dataclass(frozen=True)
class LimitCycle:
    """One solution of ``1 + G(j omega) N(A, omega) = 0``.

    Attributes
    ----------
    gain : float
        Loop gain ``K``.
    amplitude : float
        Amplitude at the element's input (= plant output, unity feedback).
    omega : float
        Angular frequency (rad/s).
    stable : bool
        Loeb's criterion (:mod:`fitdf.loop.harmonic`).
    loeb : float
        Sine of the angle between ``F_A`` and ``F_omega``; positive = stable.
    N, G : complex
        The DF and the plant's frequency response at the solution.
    residual : float
        ``|ln|GN|| + |arg(-GN)|`` after refinement.
    """

    gain: float
    amplitude: float
    omega: float
    stable: bool
    loeb: float
    N: complex
    G: complex
    residual: float

    @property
    def frequency_hz(self) -> float:
        return self.omega / (2.0 * np.pi)

    def to_dict(self) -> dict:
        return {
            "gain": self.gain,
            "amplitude": self.amplitude,
            "omega_rad_s": self.omega,
            "frequency_hz": self.frequency_hz,
            "stable": bool(self.stable),
            "loeb": self.loeb,
            "df_magnitude": float(abs(self.N)),
            "df_phase_deg": float(np.angle(self.N, deg=True)),
            "plant_magnitude": float(abs(self.G)),
            "plant_phase_deg": float(np.angle(self.G, deg=True)),
            "residual": self.residual,
        }


@dataclass(frozen=True)
class LimitCycleResponse:
    """All intersections of a gain sweep, the critical gain, and what is needed to plot them.

    Attributes
    ----------
    plant_label, nonlinearity_label : str
    gains : numpy.ndarray
    intersections : tuple of LimitCycle
        Every solution found, for every gain (ordered by gain, then amplitude).
    critical_gain : float
        Smallest ``K`` with a solution in the box (``inf``: none at any gain).
    critical_point : dict
        ``amplitude``, ``omega`` where the first solution appears, and ``at_boundary``
        (True when that is an edge of the amplitude box: the cycle then shrinks to the
        edge rather than appearing as a double root).
    amplitude_range, omega_range : tuple of float
    warnings : tuple of str
        Where harmonic balance cannot be trusted for this plant (open-loop unstable, not
        low-pass; :func:`fitdf.loop.assumptions.plant_warnings`); empty when none.
    """

    plant_label: str
    nonlinearity_label: str
    gains: np.ndarray
    intersections: tuple
    critical_gain: float
    critical_point: dict
    amplitude_range: tuple
    omega_range: tuple
    plant: LoopPlant = field(repr=False, compare=False)
    describing_function: Callable = field(repr=False, compare=False)
    warnings: tuple = ()

    def at_gain(self, gain) -> list:
        return [c for c in self.intersections if np.isclose(c.gain, gain, rtol=1e-12, atol=0)]

    def table(self) -> pd.DataFrame:
        """One row per intersection; gains without any get a row of NaN (``oscillation`` False)."""
        rows = []
        for g in self.gains:
            found = self.at_gain(g)
            for c in found:
                rows.append({**c.to_dict(), "oscillation": True})
            if not found:
                rows.append(
                    {
                        "gain": float(g),
                        "amplitude": np.nan,
                        "omega_rad_s": np.nan,
                        "frequency_hz": np.nan,
                        "stable": False,
                        "loeb": np.nan,
                        "df_magnitude": np.nan,
                        "df_phase_deg": np.nan,
                        "plant_magnitude": np.nan,
                        "plant_phase_deg": np.nan,
                        "residual": np.nan,
                        "oscillation": False,
                    }
                )
        return pd.DataFrame(rows)

    def text(self, width: int = 100) -> str:
        """The cycles of every gain as a table with its legend, the critical gain and the
        warnings (:func:`fitdf.loop.presentation.response_text`)."""
        return response_text(self.to_dict(), width)

    def __str__(self):
        return self.text()

    def stable_cycles(self, which: str = "largest") -> pd.DataFrame:
        """One row per gain: the stable cycle (largest or smallest amplitude), NaN if none."""
        t = self.table()
        rows = []
        for g in self.gains:
            s = t[(t["gain"] == g) & t["stable"]]
            if s.empty:
                rows.append(
                    {
                        "gain": float(g),
                        "amplitude": np.nan,
                        "omega_rad_s": np.nan,
                        "frequency_hz": np.nan,
                        "n_stable": 0,
                    }
                )
            else:
                r = s.sort_values("amplitude").iloc[-1 if which == "largest" else 0]
                rows.append(
                    {
                        "gain": float(g),
                        "amplitude": r["amplitude"],
                        "omega_rad_s": r["omega_rad_s"],
                        "frequency_hz": r["frequency_hz"],
                        "n_stable": len(s),
                    }
                )
        return pd.DataFrame(rows)

    def to_dict(self) -> dict:
        return {
            "plant": self.plant_label,
            "nonlinearity": self.nonlinearity_label,
            "gains": [float(g) for g in self.gains],
            "critical_gain": clean(float(self.critical_gain)),
            "critical_point": {
                k: (clean(float(v)) if isinstance(v, float) else v)
                for k, v in self.critical_point.items()
            },
            "amplitude_range": list(self.amplitude_range),
            "omega_range": list(self.omega_range),
            "intersections": [c.to_dict() for c in self.intersections],
            "warnings": list(self.warnings),
        }

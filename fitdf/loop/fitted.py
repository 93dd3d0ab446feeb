"""Limit cycles of a loop closed around a core fitted to data (what ``fitdf limit-cycle`` computes).

Fits the candidate laws to the core's measured DF (:func:`fitdf.fit`), keeps the lowest
AICc, and solves harmonic balance (:func:`fitdf.loop.harmonic.limit_cycles`) with the
fitted core's *measured* DF at the chosen source impedance.
"""

from __future__ import annotations

from dataclasses import dataclass

from fitdf._json import clean
from fitdf.errors import OptionError
from fitdf.inference.api import DEFAULT_CHAIN, fit, resolve_data
from fitdf.inference.ranking import best_by_aicc
from fitdf.loop.harmonic import LimitCycleResponse, limit_cycles
from fitdf.loop.plant import as_loop_plant
from fitdf.loop.presentation import limit_cycle_text
from fitdf.models import model_names

__all__ = ["FittedLimitCycles", "fitted_limit_cycles"]


@dataclass(frozen=True)
class FittedLimitCycles:
    """The fits tried, the one used (lowest AICc) and the harmonic-balance response."""

    data: str
    source_impedance: float
    seed: int
    time_scale: float
    fits: tuple
    best: object
    response: LimitCycleResponse

    def text(self, width: int = 100) -> str:
        """The plant, the core's fit and the cycles of every gain
        (:func:`fitdf.loop.presentation.limit_cycle_text`)."""
        return limit_cycle_text(self.to_dict(), width)

    def table(self):
        """One row per cycle (:meth:`fitdf.loop.response.LimitCycleResponse.table`)."""
        return self.response.table()

    def __str__(self):
        return self.text()

    def to_dict(self) -> dict:
        """JSON-ready record (the ``--json`` output of ``fitdf limit-cycle``)."""
        best = self.best
        return {
            "data": self.data,
            "source_impedance_ohm": float(self.source_impedance),
            "seed": int(self.seed),
            "model": best.model,
            "chain": best.chain,
            "time_scale": float(self.time_scale),
            "models_tried": [
                {
                    "model": r.model,
                    "aicc": clean(float(r.metrics["aicc"])),
                    "rms_complex": clean(float(r.metrics["rms_complex"])),
                }
                for r in self.fits
            ],
            "parameters": {k: clean(float(v)) for k, v in best.values.items()},
            **self.response.to_dict(),
        }


def _fit_law(data, model, chain, seed, source_impedance, n_starts):
    """One law's least-squares fit (a job of :func:`fitted_limit_cycles`)."""
    return fit(
        data, model, chain=chain, seed=seed, source_impedance=source_impedance, n_starts=n_starts
    )


def fitted_limit_cycles(
    data,
    plant,
    gains,
    source_impedance,
    model=None,
    chain=DEFAULT_CHAIN,
    seed=0,
    *,
    amplitude_range=None,
    omega_range=None,
    time_scale=1.0,
    n_starts=6,
    runner=None,
) -> FittedLimitCycles:
    """Fit the core, then find the limit cycles of the loop closed around it.

    Parameters
    ----------
    data : str
        Dataset (``"B.3"``), core or CSV path.
    plant : str
        Transfer function text, e.g. ``"K/((1+s)(1+0.25s)(1+1.1s))"``.
    gains : sequence of float
        Loop gains (replace ``K``; multiply the plant when it has no ``K``).
    source_impedance : float or None
        Ohm; selects the data rows and the DF used in the loop (None: the data's only
        source impedance; an OptionError if they hold several).
    model, chain, seed
        As in :func:`fitdf.fit`; ``model=None`` fits every law and keeps the lowest AICc.
    amplitude_range, omega_range, time_scale
        As in :func:`fitdf.loop.harmonic.limit_cycles`.
    n_starts : int
        Least-squares starts per model.
    runner : callable, optional
        Runs the fits: ``runner(jobs, desc) -> results`` on ``{key: (function, args)}``, such
        as :meth:`fitdf.executor.Executor.run` with a job cache (``fitdf limit-cycle``
        keeps its fits as ``fitdf fit`` does); None fits here, one law after the other.
    """
    lp = as_loop_plant(plant, time_scale)  # a bad plant fails now, before any fitting
    rows = resolve_data(data, source_impedance=source_impedance)  # and so do bad data
    if source_impedance is None:  # one impedance in the data: use it; several: the user must choose
        found = sorted(set(rows.source_impedance.tolist()))
        if len(found) != 1:
            raise OptionError(
                f"{data}: rows at several source impedances ({', '.join(f'{r:g}' for r in found)} "
                "ohm); choose one with --source-impedance"
            )
        source_impedance = found[0]
    names = [model] if model else model_names()
    # keyed by position too, as compare_fits keys its fits: a law listed twice is fitted twice
    jobs = {
        (i, name, chain): (_fit_law, (data, name, chain, seed, source_impedance, n_starts))
        for i, name in enumerate(names)
    }
    if runner is None:
        fits = tuple(fn(*args) for fn, args in jobs.values())
    else:
        fits = tuple(runner(jobs, "fitting").values())
    best = best_by_aicc(fits)
    resp = limit_cycles(
        lp,
        best,
        gains,
        source_impedance=source_impedance,
        amplitude_range=amplitude_range,
        omega_range=omega_range,
    )
    return FittedLimitCycles(
        str(data), float(source_impedance), int(seed), float(time_scale), fits, best, resp
    )

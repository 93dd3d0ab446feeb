"""Series permeability compared at matched flux amplitude: rate dependence told from amplitude.

A reading inverted through the circuit of Fig 5.10 gives the winding's series permeability
``mu'`` and quality factor ``Q`` (:func:`fitdf.inference.small_signal.series_permeability`).
Both depend on the flux amplitude as well as on the frequency: a rate-independent loop's
``mu'`` rises with the flux from its initial value (Rayleigh, eq 3.7), so readings at
different frequencies show a rate dependence only when they are compared at the same flux.
The flux amplitude of a reading is its EMF over ``w``, ``Lambda = |DF| V / (gain w)`` (the
output is the winding's EMF times the gain, section V.5).

:func:`matched_flux` takes a fit of one table at one source impedance (a block per
frequency) and, optionally, its refit through a rate-dependent chain, and puts the rows and
both laws on a common flux axis:

* **levels**: the smallest flux each frequency's rows reach, and :data:`DOUBLINGS` doublings
  of the largest of them (the *common* level, the smallest flux every frequency reaches)
  where every frequency's rows still span them. At each level, every frequency whose rows
  span it gives ``mu'`` and ``Q``, interpolated linearly in ``ln Lambda`` between its two
  neighbouring rows (the level's own frequency gives its row); each law gives its own
  ``mu'`` and ``Q`` there, from its predictions on a fine grid of inputs.
* **the printed precision**: every row's DF and phase drawn uniformly within half a unit of
  their last printed digit (:func:`fitdf.data.precision.reading_resolution`) and the whole
  comparison repeated per draw; ``*_lo``/``*_hi`` are the central 95 % of the draws.
* **the frequency dependence at each level**: a power law ``mu' ~ f^slope`` fitted to the
  frequencies by least squares in logarithms, with the standard error the frequencies'
  scatter about it gives (``slope_se``, ``scatter``: RMS of the residuals, a relative
  deviation) and its 95 % interval (Student's t with ``n - 2`` degrees of freedom), beside
  the part the printed precision explains (``slope_precision``, ``precision``: the draws'
  standard deviations).
* **the rise at small flux**: per frequency, ``mu'`` at the common level (the smallest flux
  every frequency reaches) over ``mu'`` at its own smallest flux, rows and laws.

The rows are inverted with each fit's own series resistance and gain; the rows and the
static law are compared through the static fit's, the dynamic law through its own.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import stats

from fitdf.inference.permeability import (
    core_geometry_of,
    drawn_permeability,
    fit_circuit,
    law_curves,
    row_permeability,
)

__all__ = [
    "MatchedFlux",
    "matched_flux",
    "log_interp",
    "DRAWS",
    "DOUBLINGS",
]

#: Draws of the printed precision (uniform within half a unit of each printed digit).
DRAWS = 2000
#: Levels above the common one: its doublings (2, 4, 8 times), about a third of the
#: saturation flux on Table B.4, below the knee where the inversion loses its precision.
DOUBLINGS = 3
_QUANTILES = (2.5, 97.5)


def log_interp(level, flux, values):
    """``values`` at the flux ``level``, linear in ``ln flux`` between the two neighbouring
    points and along the end segment beyond them. ``flux`` and ``values`` (complex allowed)
    have the points on their last axis, in any order; leading axes are a batch."""
    flux, values = np.asarray(flux, float), np.asarray(values)
    order = np.argsort(flux, axis=-1, kind="stable")
    x = np.log(np.take_along_axis(flux, order, -1))
    y = np.take_along_axis(values, order, -1)
    if x.shape[-1] == 1:
        return y[..., 0]
    t = np.log(float(level))
    k = np.clip(np.sum(x < t, axis=-1) - 1, 0, x.shape[-1] - 2)[..., None]
    x0, x1 = np.take_along_axis(x, k, -1), np.take_along_axis(x, k + 1, -1)
    y0, y1 = np.take_along_axis(y, k, -1), np.take_along_axis(y, k + 1, -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(x1 > x0, (t - x0) / (x1 - x0), 0.0)
    return (y0 + w * (y1 - y0))[..., 0]


def _rising(flux, amplitude) -> np.ndarray:
    """Positions, in input order, of the points from the smallest input up to the last one
    before the flux first stops rising: the stretch on which the flux orders them."""
    order = np.argsort(amplitude, kind="stable")
    stop = np.flatnonzero(np.diff(flux[order]) <= 0)
    return order[: stop[0] + 1] if stop.size else order


def _complex(frame):
    return frame["mu"].to_numpy() - 1j * frame["mu_loss"].to_numpy()


def _on_axis(frame, f):
    """``(flux, complex mu)`` of ``frame``'s rising stretch at frequency ``f``."""
    mine = frame[frame["frequency_hz"] == f]
    rise = _rising(mine["flux_vs"].to_numpy(), mine["input_v"].to_numpy())
    return mine["flux_vs"].to_numpy()[rise], _complex(mine)[rise]


def _law_at(level, curve):
    flux, mu = curve
    inside = flux.size and flux.min() <= level <= flux.max()
    return complex(log_interp(level, flux, mu)) if inside else complex(np.nan, np.nan)


def _levels(rows: pd.DataFrame) -> np.ndarray:
    """The smallest flux of each frequency's rows, sorted, one level for those within 1e-9."""
    first = rows.loc[rows.groupby("frequency_hz")["input_v"].idxmin(), "flux_vs"].to_numpy()
    first = np.sort(first)
    keep = np.concatenate([[True], np.diff(first) > 1e-9 * first[1:]])
    return first[keep]


def _interval(x) -> tuple[float, float]:
    lo, hi = np.nanpercentile(x, _QUANTILES) if np.isfinite(x).any() else (np.nan, np.nan)
    return float(lo), float(hi)


def _power_law(frequency, mu):
    """Least-squares slope of ``ln mu`` on ``ln f`` (points on the last axis), its standard
    error from the residuals and their RMS; NaN from fewer than 2 points (3 for the error and
    the RMS: two points leave no residual) or where ``mu <= 0``."""
    x = np.log(np.asarray(frequency, float))
    with np.errstate(invalid="ignore", divide="ignore"):
        y = np.log(np.asarray(mu, float))
    n = x.size
    if n < 2:
        nan = np.full(np.shape(y)[:-1], np.nan)
        return nan, nan, nan
    xc = x - x.mean()
    slope = np.sum(xc * (y - y.mean(axis=-1, keepdims=True)), axis=-1) / np.sum(xc**2)
    resid = y - y.mean(axis=-1, keepdims=True) - slope[..., None] * xc
    if n < 3:
        nan = np.full(np.shape(slope), np.nan)
        return slope, nan, nan
    rms = np.sqrt(np.mean(resid**2, axis=-1))
    se = np.sqrt(np.sum(resid**2, axis=-1) / (n - 2) / np.sum(xc**2))
    return slope, se, rms


@dataclass(frozen=True)
class MatchedFlux:
    """The rows and the laws on a common flux axis (:func:`matched_flux`).

    Attributes
    ----------
    levels : pandas.DataFrame
        One row per (flux level, frequency whose rows span it): ``level_vs``,
        ``frequency_hz``, ``own`` (the level is this frequency's smallest flux), the rows'
        ``mu`` and ``q`` with the printed precision's ``mu_lo``/``mu_hi`` and
        ``q_lo``/``q_hi`` (``q_hi`` inf where a draw is lossless), the static law's
        ``mu_static``/``q_static``, and, with a dynamic refit, the rows inverted with its
        series resistance and gain ``mu_rows_dynamic`` and its law's
        ``mu_dynamic``/``q_dynamic``.
    frequency : pandas.DataFrame
        One row per level: ``n_frequencies``, ``mu_min``, ``mu_max``, ``ratio`` (max over
        min), ``first_over_last`` (the lowest frequency's ``mu`` over the highest's), the
        power law's ``slope``,
        ``slope_se``, ``scatter`` and the printed precision's ``slope_precision`` and
        ``precision`` (RMS over the frequencies of the draws' standard deviation of
        ``ln mu``); ``slope_static``, ``slope_dynamic`` and ``first_over_last_dynamic`` of
        the laws at the same frequencies.
    small_flux : pandas.DataFrame
        One row per frequency: its smallest flux ``flux_vs`` and the ``common_vs`` level,
        the rows' ``mu`` at ``flux_vs`` (with ``mu_lo``/``mu_hi``), the laws' there, and
        the rise ``mu(common) / mu(flux_vs)`` of the rows (``rise`` with ``rise_lo`` /
        ``rise_hi``), of the static law and of the dynamic (``rise_rows_dynamic``: the rows
        inverted as for the dynamic law).
    rows : pandas.DataFrame
        Every row (:func:`row_permeability`, the static fit's inversion) with the printed
        precision's ``mu_lo``/``mu_hi`` and ``flux_lo``/``flux_hi``.
    curves : dict
        ``"static"`` (and ``"dynamic"``) -> :func:`law_curves`.
    fits : dict
        Per fit: ``model``, ``chain``, ``gain``, ``r_total_ohm``.
    common_vs : float
        The smallest flux every frequency's rows reach.
    draws, seed : int
        Of the printed precision.
    """

    levels: pd.DataFrame
    frequency: pd.DataFrame
    small_flux: pd.DataFrame
    rows: pd.DataFrame
    curves: dict = field(repr=False)
    fits: dict
    common_vs: float
    draws: int
    seed: int

    def to_dict(self) -> dict:
        """Plain lists and numbers (NaN and inf stay: :func:`fitdf._json.clean` makes them null)."""
        records = lambda frame: frame.to_dict(orient="list")  # noqa: E731
        return {
            "common_vs": float(self.common_vs),
            "fits": self.fits,
            "draws": int(self.draws),
            "seed": int(self.seed),
            "levels": self.levels.to_dict(orient="records"),
            "frequency": self.frequency.to_dict(orient="records"),
            "small_flux": self.small_flux.to_dict(orient="records"),
            "rows": records(self.rows),
            "curves": {k: records(v) for k, v in self.curves.items()},
        }


def matched_flux(static, dynamic=None, *, geometry=None, draws=DRAWS, seed=0) -> MatchedFlux:
    """Compare a fit's rows and laws at matched flux amplitude (module docstring).

    Parameters
    ----------
    static : FitResult
        A fit of one table at one source impedance, several frequencies, with a core
        geometry (its own or ``geometry``).
    dynamic : FitResult, optional
        The same rows refitted through a rate-dependent chain (``dynamic``).
    geometry : CoreGeometry, optional
    draws, seed : int
        Draws of the printed precision and their seed.

    Returns
    -------
    MatchedFlux
    """
    geometry = core_geometry_of(static, geometry)
    fits = {"static": static, **({"dynamic": dynamic} if dynamic is not None else {})}
    rows = row_permeability(static, geometry)
    curves = {k: law_curves(r, geometry) for k, r in fits.items()}
    rows_dyn = row_permeability(dynamic, geometry) if dynamic is not None else None
    d_flux, d_mu = drawn_permeability(static, geometry, draws, seed)
    flux, freq, inp = (rows[c].to_numpy() for c in ("flux_vs", "frequency_hz", "input_v"))
    stretch = {}  # frequency -> positions of its rising stretch
    for f in np.unique(freq):
        mine = np.flatnonzero(freq == f)
        stretch[f] = mine[_rising(flux[mine], inp[mine])]
    anchors = _levels(rows)
    common = anchors[-1]
    top = min(flux[r].max() for r in stretch.values())
    above = common * 2.0 ** np.arange(1, DOUBLINGS + 1)
    levels = np.concatenate([anchors, above[above <= top]])
    table, drawn = _at_levels(levels, stretch, rows, rows_dyn, curves, (d_flux, d_mu))
    levels = pd.DataFrame(table).sort_values(["level_vs", "frequency_hz"], ignore_index=True)
    lo, hi = (np.percentile(d_mu.real, q, axis=0) for q in _QUANTILES)
    f_lo, f_hi = (np.percentile(d_flux, q, axis=0) for q in _QUANTILES)
    by_level = _by_level(levels, drawn)
    scatter = float(by_level.loc[by_level["level_vs"] == common, "scatter"].iloc[0])
    return MatchedFlux(
        levels=levels,
        frequency=by_level,
        small_flux=_small_flux(levels, drawn, common, scatter),
        rows=rows.assign(mu_lo=lo, mu_hi=hi, flux_lo=f_lo, flux_hi=f_hi),
        curves=curves,
        fits={k: _fit_record(r) for k, r in fits.items()},
        common_vs=float(common),
        draws=int(draws),
        seed=int(seed),
    )


def _at_levels(levels, stretch, rows, rows_dyn, curves, drawn_rows):
    """One record per (level, frequency whose rising stretch spans it), and the draws of the
    rows' complex ``mu`` there, keyed the same way."""
    flux, mu_all = rows["flux_vs"].to_numpy(), _complex(rows)
    d_flux, d_mu = drawn_rows
    table, drawn = [], {}
    for f, rise in stretch.items():
        own = flux[rise][0]
        laws = {k: _on_axis(c, f) for k, c in curves.items()}
        for level in levels:
            if not flux[rise].min() * (1 - 1e-9) <= level <= flux[rise].max() * (1 + 1e-9):
                continue
            mu = complex(log_interp(level, flux[rise], mu_all[rise]))
            drawn[(level, f)] = log_interp(level, d_flux[:, rise], d_mu[:, rise])
            row = {
                "level_vs": float(level),
                "frequency_hz": float(f),
                "own": bool(abs(level - own) <= 1e-9 * own),
                **_summary(mu, drawn[(level, f)]),
                **_law("static", _law_at(level, laws["static"])),
            }
            if rows_dyn is not None:  # the same rows, inverted with the refit's R and gain
                mine = rows_dyn.iloc[rise]
                mu_dyn = log_interp(level, mine["flux_vs"].to_numpy(), _complex(mine))
                row["mu_rows_dynamic"] = float(np.real(mu_dyn))
                row.update(_law("dynamic", _law_at(level, laws["dynamic"])))
            table.append(row)
    return table, drawn


def _fit_record(result) -> dict:
    gain, r_total = fit_circuit(result)
    return {"model": result.model, "chain": result.chain, "gain": gain, "r_total_ohm": r_total}


def _summary(mu: complex, drawn) -> dict:
    """The rows' ``mu``, ``q`` and their printed-precision intervals at one level."""
    m_lo, m_hi = _interval(drawn.real)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_lo, t_hi = _interval(-drawn.imag / drawn.real)  # the loss tangent 1/Q: continuous at 0
        q = mu.real / -mu.imag
    return {
        "mu": mu.real,
        "mu_lo": m_lo,
        "mu_hi": m_hi,
        "q": q,
        "q_lo": 1.0 / t_hi if t_hi > 0 else np.inf,
        "q_hi": 1.0 / t_lo if t_lo > 0 else np.inf,
    }


def _law(name: str, mu: complex) -> dict:
    with np.errstate(divide="ignore", invalid="ignore"):
        return {f"mu_{name}": mu.real, f"q_{name}": mu.real / -mu.imag}


def _by_level(levels: pd.DataFrame, drawn: dict) -> pd.DataFrame:
    out = []
    for level, t in levels.groupby("level_vs", sort=True):
        f, mu = t["frequency_hz"].to_numpy(), t["mu"].to_numpy()
        draws = np.stack([drawn[(level, x)].real for x in f], axis=-1)
        slope, se, rms = _power_law(f, mu)
        d_slope = _power_law(f, draws)[0]
        with np.errstate(invalid="ignore", divide="ignore"):
            sd = np.nanstd(np.log(draws), axis=0)
        row = {
            "level_vs": float(level),
            "n_frequencies": int(f.size),
            "frequencies_hz": [float(x) for x in f],
            "mu_min": float(mu.min()),
            "mu_max": float(mu.max()),
            "ratio": float(mu.max() / mu.min()),
            "first_over_last": float(mu[0] / mu[-1]),
            "slope": float(slope),
            "slope_se": float(se),
            **_slope_interval(slope, se, f.size),
            "scatter": float(rms),
            "slope_precision": float(np.nanstd(d_slope)) if f.size > 1 else np.nan,
            "precision": float(np.sqrt(np.mean(sd**2))),
            "slope_static": float(_power_law(f, t["mu_static"].to_numpy())[0]),
        }
        if "mu_dynamic" in t:
            dyn = t["mu_dynamic"].to_numpy()
            row["slope_dynamic"] = float(_power_law(f, dyn)[0])
            row["first_over_last_dynamic"] = float(dyn[0] / dyn[-1])
        for law in ("static", "dynamic"):
            if f"slope_{law}" in row:  # the law's slope inside the rows' 95 % interval
                row[f"contains_{law}"] = (
                    bool(row["slope_lo"] <= row[f"slope_{law}"] <= row["slope_hi"])
                    if f.size > 2
                    else None
                )
        out.append(row)
    return pd.DataFrame(out)


def _slope_interval(slope, se, n) -> dict:
    """The 95 % interval of a power law's slope from ``n`` points (Student's t, ``n - 2``
    degrees of freedom); NaN below 3 points."""
    if n < 3:
        return {"slope_lo": np.nan, "slope_hi": np.nan}
    half = float(stats.t.ppf(0.975, n - 2)) * float(se)
    return {"slope_lo": float(slope) - half, "slope_hi": float(slope) + half}


def _small_flux(levels: pd.DataFrame, drawn: dict, common: float, scatter: float) -> pd.DataFrame:
    out = []
    at_common = levels[levels["level_vs"] == common].set_index("frequency_hz")
    for _, own in levels[levels["own"]].iterrows():
        f, level = own["frequency_hz"], own["level_vs"]
        top = at_common.loc[f]
        rise = drawn[(common, f)].real / drawn[(level, f)].real
        r_lo, r_hi = _interval(rise)
        row = {
            "frequency_hz": float(f),
            "flux_vs": float(level),
            "common_vs": float(common),
            "mu": float(own["mu"]),
            "mu_lo": float(own["mu_lo"]),
            "mu_hi": float(own["mu_hi"]),
            "q": float(own["q"]),
            "q_lo": float(own["q_lo"]),
            "q_hi": float(own["q_hi"]),
            "mu_static": float(own["mu_static"]),
            "rise": float(top["mu"] / own["mu"]),
            "rise_lo": r_lo,
            "rise_hi": r_hi,
            "rise_static": float(top["mu_static"] / own["mu_static"]),
            "over_static": float(own["mu"] / own["mu_static"]),
            "scatters_from_static": float(np.log(own["mu"] / own["mu_static"]) / scatter),
        }
        if "mu_dynamic" in own:
            row["mu_dynamic"] = float(own["mu_dynamic"])
            row["mu_rows_dynamic"] = float(own["mu_rows_dynamic"])
            row["rise_dynamic"] = float(top["mu_dynamic"] / own["mu_dynamic"])
            row["rise_rows_dynamic"] = float(top["mu_rows_dynamic"] / own["mu_rows_dynamic"])
            row["over_dynamic"] = float(own["mu_rows_dynamic"] / own["mu_dynamic"])
        out.append(row)
    return pd.DataFrame(out)

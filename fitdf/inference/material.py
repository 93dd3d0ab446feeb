"""Material constants of a fitted core, read off the fitted loop, and their Appendix A check.

A fitted law lives in winding units (current in A, flux linkage in V s). Given the core's
:class:`~fitdf.data.cores.CoreGeometry`, :func:`material_constants` converts the loop to the
units in which manufacturers, and Appendix A of the thesis, characterise a core
(permeabilities in gauss/oersted, inductions in gauss, the coercive force in oersted), and
:func:`appendix_a_check` compares them with the printed ranges:

* **initial permeability** ``mu_i``: the small-signal inductance ``Re N`` at
  ``a = 1e-6 current_max`` (:data:`SMALL_SIGNAL_RATIO`), flagged when ``Re N`` still moves
  by more than 1 % over the decade above;
* **maximum permeability** ``mu_max``: the largest amplitude permeability
  ``B_tip / H_tip = ascending_branch(a, a) / a`` over ``0 < a <= current_max`` (the tips of
  the symmetric loops trace the normal magnetisation curve); a lower bound only
  (``maximum_at_edge``) when it sits at ``current_max``;
* **coercive force** ``H_c``: the zero of the ascending branch of the largest loop
  (``a = current_max``), NaN for a loop without height;
* **peak flux density** ``B_p = ascending_branch(a, a)``, **residual induction**
  ``B_r = -ascending_branch(0, a)`` of the largest loop, and the squareness ``B_r / B_p``;
* the fitted **series resistance** (winding, source output and leads) against the 95 %
  interval of its prior about the winding's Appendix A estimate
  (:func:`fitdf.chains.series_resistance.series_resistance_prior`).

Notes
-----
Every constant comes from the loop itself (:meth:`ascending_branch` and
:meth:`describing_function` of whatever law was fitted), never from a per-law formula, so
every law is judged by the same yardstick; for the Rayleigh loop they are the thesis's
closed forms (``mu_i`` is eq 3.1's ``mu0``, ``B_r`` eq 3.9, ``H_c`` eq 3.10), which
``tests/test_material.py`` checks. ``mu_i`` comes from the in-phase fundamental and
``mu_max`` from the secant to the loop's tip, as the catalogues define them; a law whose
loop keeps a finite width as ``a -> 0`` (eq 4.2) can give ``mu_i > mu_max``. The
parameters must be in winding units, i.e. come from a fit through the ``voltage`` or
``winding`` chain: the ``direct`` chain fits a dimensionless ratio, which has no material
constants. A frequency-dependent law is evaluated at one frequency (the caller's choice;
fits use their lowest data frequency).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from fitdf._json import clean
from fitdf.chains import series_resistance_prior
from fitdf.data.cores import CoreGeometry, appendix_a_ranges
from fitdf.errors import ModelError, OptionError
from fitdf.inference.caveats import undetermined_parameters
from fitdf.inference.presentation import MaterialRecord
from fitdf.params import PER_TABLE, parameter_base

__all__ = [
    "MaterialConstants",
    "material_constants",
    "material_record",
    "with_material",
    "loop_landmarks",
    "appendix_a_check",
    "inductance_from_permeability",
    "permeability_from_inductance",
    "current_from_field",
    "field_from_current",
    "flux_linkage_from_induction",
    "induction_from_flux_linkage",
    "SMALL_SIGNAL_RATIO",
    "RESISTANCE_PRIOR_SIGMAS",
    "CHECK_QUANTITIES",
    "DETERMINED_BY",
    "implied_stacking_factor",
]

#: Amplitude, relative to ``current_max``, at which ``Re N`` is taken as the small-signal limit.
SMALL_SIGNAL_RATIO = 1e-6
#: Relative change of ``Re N`` over the decade above the small-signal amplitude beyond which
#: the initial permeability is flagged as not converged.
_CONVERGENCE_TOL = 1e-2
#: The band accepted for the series resistance: its prior's median times or over
#: ``exp(RESISTANCE_PRIOR_SIGMAS sigma)`` (2: about the central 95 %).
RESISTANCE_PRIOR_SIGMAS = 2.0
#: Rows of :func:`appendix_a_check`, named as in ``datasets/appendix_a.csv`` (plus the resistance).
CHECK_QUANTITIES = (
    "initial_permeability",
    "maximum_permeability",
    "coercive_force_Hc",
    "peak_flux_density_Bp",
    "residual_induction_Br",
    "squareness_Br_over_Bp",
    "series_resistance",
)

#: What a fit's data determine of each constant, as the constant depends on the two things
#: DF data leave open: the iron fraction (inductions and permeabilities scale as its inverse,
#: the squareness and fields do not) and, with data at one source impedance, the current
#: scale (fields and permeabilities scale with it, flux linkages do not; :mod:`fitdf.data.cores`):
#: ``quantity -> (depends on the iron fraction, depends on the current scale)``.
_DEPENDS = {
    "initial_permeability": (True, True),
    "maximum_permeability": (True, True),
    "coercive_force_Hc": (False, True),
    "peak_flux_density_Bp": (True, False),
    "residual_induction_Br": (True, False),
    "squareness_Br_over_Bp": (False, False),
    "series_resistance": (False, True),
}
#: The sentence for each combination (iron fraction, current scale left open).
DETERMINED_BY = {
    (False, False): "by the data",
    (True, False): "by the data up to the iron fraction",
    (False, True): "by the series-resistance prior (one source impedance: the current scale)",
    (True, True): "by the series-resistance prior and up to the iron fraction",
}


def _determined(quantity, joint: bool) -> str:
    iron, scale = _DEPENDS[quantity]
    return DETERMINED_BY[(iron, scale and not joint)]


# Amplitude grid of the maximum-permeability search: a geometric first pass over
# [SMALL_SIGNAL_RATIO, 1] current_max, then linear refinements of the best bracket.
_MAX_GRID, _MAX_REFINE_GRID, _MAX_REFINE_STAGES = 257, 65, 6
# Zero-crossing search: each stage cuts the bracket into 63 pieces; 9 stages shrink it
# by 63^9 ~ 1.6e16, below the rounding of x.
_ZERO_GRID, _ZERO_STAGES = 64, 9


def _float(value):
    v = np.asarray(value, dtype=float)
    return float(v) if v.ndim == 0 else v


def _model_kwargs(model, theta):
    """The model's own parameters out of ``theta`` (chain parameters such as ``r_series`` dropped)."""
    names = [p.name for p in getattr(model, "params", ())]
    if not names:
        raise ModelError(f"{model!r} declares no parameters (expected a HysteresisModel class)")
    return {name: float(theta[name]) for name in names if name in theta}


def _model_name(model):
    return str(getattr(model, "name", getattr(model, "__name__", repr(model))))


def _frequency(model, frequency):
    if frequency is None:
        if getattr(model, "frequency_dependent", False):
            raise OptionError(
                f"model {_model_name(model)!r} depends on frequency: give the frequency "
                "(e.g. the lowest frequency of the data)"
            )
        return 0.0
    f = float(frequency)
    if not (math.isfinite(f) and f >= 0):
        raise OptionError(f"frequency must be a finite non-negative number, got {frequency!r}")
    return f


def loop_landmarks(model, amplitudes, frequency=0.0, **theta):
    """Tip, remanence and coercive current of the loops of peak current ``amplitudes``.

    Vectorised over ``amplitudes``: every branch evaluation is one call on an
    ``(n_amplitudes, n_grid)`` array.

    Parameters
    ----------
    model : type
        Hysteresis law (duck typed: ``ascending_branch(x, amplitude, frequency, **theta)``).
    amplitudes : array_like
        Peak currents ``a > 0`` (A), 1-D.
    frequency : float
        Frequency (Hz) passed to the branch.
    **theta
        The law's parameters (scalars).

    Returns
    -------
    dict of numpy.ndarray
        ``tip`` = ``ascending_branch(a, a)`` (V s, the loop's peak flux linkage),
        ``residual`` = ``-ascending_branch(0, a)`` (V s, the remanence ``B_r`` of eq 3.9 in
        winding units) and ``coercive`` (A): the smallest ``x`` in ``[-a, a]`` where the
        ascending branch reaches zero (``H_c``, eq 3.10 for the Rayleigh loop), NaN where
        the branch does not go from negative at ``x = -a`` to positive at ``x = a``.
        The zero is bracketed on a grid of 64 points, refined 9 times (bracket shrunk by
        ``63^9``); a non-decreasing branch is assumed (a passive core's), otherwise the
        first upward crossing is returned.
    """
    a = np.atleast_1d(np.asarray(amplitudes, dtype=float))
    if a.ndim != 1 or np.any(~np.isfinite(a)) or np.any(a <= 0):
        raise OptionError("amplitudes must be a 1-D array of positive finite currents")
    ends = model.ascending_branch(
        np.stack([-a, np.zeros_like(a), a], axis=1), a[:, None], frequency, **theta
    )
    ends = np.broadcast_to(np.asarray(ends, dtype=float), (a.size, 3))
    bottom, at_zero, tip = ends[:, 0], ends[:, 1], ends[:, 2]
    crosses = (bottom < 0) & (tip > 0)

    lo, hi = -a.copy(), a.copy()
    t = np.linspace(0.0, 1.0, _ZERO_GRID)
    rows = np.arange(a.size)
    for _ in range(_ZERO_STAGES):
        x = lo[:, None] + (hi - lo)[:, None] * t
        x[:, -1] = hi  # keep the bracket's end exact
        y = np.broadcast_to(
            np.asarray(model.ascending_branch(x, a[:, None], frequency, **theta), dtype=float),
            x.shape,
        )
        j = np.argmax(y >= 0, axis=1)  # first grid point at or above zero
        j = np.clip(j, 1, _ZERO_GRID - 1)  # y[:, 0] < 0 wherever a crossing exists
        lo, hi = x[rows, j - 1], x[rows, j]
    coercive = np.where(crosses, 0.5 * (lo + hi), np.nan)
    return {"tip": tip.copy(), "residual": -at_zero, "coercive": coercive}


def _tip_ratio(model, a, frequency, theta):
    tip = model.ascending_branch(a, a, frequency, **theta)
    return np.broadcast_to(np.asarray(tip, dtype=float), a.shape) / a


def _maximum_amplitude_inductance(model, current_max, frequency, theta):
    """Largest ``ascending_branch(a, a) / a`` over ``SMALL_SIGNAL_RATIO current_max <= a <= current_max``."""
    a = np.geomspace(SMALL_SIGNAL_RATIO * current_max, current_max, _MAX_GRID)
    a[-1] = current_max
    for stage in range(_MAX_REFINE_STAGES + 1):
        ratio = _tip_ratio(model, a, frequency, theta)
        ratio = np.where(np.isfinite(ratio), ratio, -np.inf)
        i = int(np.argmax(ratio))
        best_a, best = float(a[i]), float(ratio[i])
        if stage == _MAX_REFINE_STAGES:
            break
        lo, hi = a[max(i - 1, 0)], a[min(i + 1, a.size - 1)]
        a = np.linspace(lo, hi, _MAX_REFINE_GRID)
    return best, best_a


@dataclass(frozen=True)
class MaterialConstants:
    """Material constants of a fitted core (SI and Appendix A units).

    Built by :func:`material_constants`; every number is a plain ``float`` (NaN where
    undefined). ``*_h`` inductances in henry, ``*_a`` currents in ampere, ``*_vs`` flux
    linkages in volt-second; permeabilities are relative (numerically gauss/oersted).

    Attributes
    ----------
    model : str
        Name of the law.
    frequency_hz, current_max_a : float
        Frequency the law was evaluated at and the largest peak current of the data.
    initial_inductance_h, initial_permeability : float
        ``L0 = Re N(1e-6 current_max)`` and its ``mu_i``.
    initial_relative_change : float
        ``|Re N(1e-5 I) - Re N(1e-6 I)| / |Re N(1e-6 I)|`` (0 when both vanish).
    initial_converged : bool
        ``initial_relative_change <= 1e-2``.
    maximum_inductance_h, maximum_permeability, maximum_amplitude_a : float
        Largest amplitude inductance ``B_tip/H_tip`` in winding units, as ``mu_max``, and
        the peak current where it occurs.
    maximum_at_edge : bool
        The largest value is at ``current_max``: a lower bound only.
    coercive_current_a, coercive_force_a_per_m, coercive_force_oe : float
        ``H_c`` of the largest loop.
    peak_flux_linkage_vs, peak_flux_density_t, peak_flux_density_gauss : float
        ``B_p``: tip of the largest loop.
    residual_flux_linkage_vs, residual_induction_t, residual_induction_gauss : float
        ``B_r``: the descending branch at zero current (eq 3.9).
    squareness : float
        ``B_r / B_p``.
    series_resistance_ohm, winding_resistance_estimate_ohm : float
        The fitted resistance and the Appendix A estimate (NaN if not given).
    geometry : CoreGeometry
        The geometry used for the conversions.
    """

    model: str
    frequency_hz: float
    current_max_a: float
    initial_inductance_h: float
    initial_permeability: float
    initial_relative_change: float
    initial_converged: bool
    maximum_inductance_h: float
    maximum_permeability: float
    maximum_amplitude_a: float
    maximum_at_edge: bool
    coercive_current_a: float
    coercive_force_a_per_m: float
    coercive_force_oe: float
    peak_flux_linkage_vs: float
    peak_flux_density_t: float
    peak_flux_density_gauss: float
    residual_flux_linkage_vs: float
    residual_induction_t: float
    residual_induction_gauss: float
    squareness: float
    series_resistance_ohm: float
    winding_resistance_estimate_ohm: float
    geometry: CoreGeometry = field(repr=False)

    def appendix_a_values(self) -> dict[str, float]:
        """The constants under their ``datasets/appendix_a.csv`` names, in Appendix A units.

        Permeabilities in gauss/oersted, ``coercive_force_Hc`` in oersted, inductions in
        gauss, the squareness as a ratio, ``series_resistance`` and
        ``winding_resistance_estimate`` in ohm.
        """
        return {
            "initial_permeability": self.initial_permeability,
            "maximum_permeability": self.maximum_permeability,
            "coercive_force_Hc": self.coercive_force_oe,
            "peak_flux_density_Bp": self.peak_flux_density_gauss,
            "residual_induction_Br": self.residual_induction_gauss,
            "squareness_Br_over_Bp": self.squareness,
            "series_resistance": self.series_resistance_ohm,
            "winding_resistance_estimate": self.winding_resistance_estimate_ohm,
        }

    def to_dict(self) -> dict:
        """Plain dict (floats, bools, str; the geometry as :meth:`CoreGeometry.to_dict`)."""
        out = {k: getattr(self, k) for k in self.__dataclass_fields__ if k != "geometry"}
        out["geometry"] = self.geometry.to_dict()
        return out


def material_constants(
    model,
    theta,
    geometry: CoreGeometry,
    *,
    current_max,
    frequency=None,
    series_resistance=None,
    winding_resistance_estimate=None,
) -> MaterialConstants:
    """Material constants of a fitted law on a given core (see the module docstring).

    Parameters
    ----------
    model : type
        The law's class (duck typed: ``ascending_branch``, ``describing_function``,
        ``params``; optional ``name`` and ``frequency_dependent``).
    theta : mapping
        Parameter values by name, in winding units; keys that are not parameters of the
        law (the chain's ``r_series``, ``gain``) are ignored.
    geometry : CoreGeometry
        Turns and dimensions (:func:`fitdf.data.cores.core_geometry` for a thesis core,
        :meth:`CoreGeometry.from_dimensions` for another).
    current_max : float
        Largest peak winding current the data reached (A): the largest loop, and the upper
        end of the maximum-permeability search (no extrapolation beyond the data).
    frequency : float, optional
        Frequency (Hz) at which the law is evaluated; required for a frequency-dependent
        law (use the lowest data frequency: an assumption, the catalogue's test frequency
        is not printed), 0 otherwise.
    series_resistance : float, optional
        Fitted winding resistance (ohm), e.g. the winding chain's ``r_series``; if None,
        ``theta["r_series"]`` when present.
    winding_resistance_estimate : float, optional
        Independent estimate (ohm); defaults to ``geometry.r_winding_estimate``.

    Returns
    -------
    MaterialConstants
    """
    if not isinstance(geometry, CoreGeometry):
        raise OptionError(f"geometry must be a CoreGeometry, got {type(geometry).__name__}")
    i_max = float(current_max)
    if not (math.isfinite(i_max) and i_max > 0):
        raise OptionError(f"current_max must be a positive finite current, got {current_max!r}")
    f = _frequency(model, frequency)
    kw = _model_kwargs(model, theta)

    # Initial permeability: Re N at 1e-6 and 1e-5 of current_max, in one call.
    small = np.array([SMALL_SIGNAL_RATIO, 10.0 * SMALL_SIGNAL_RATIO]) * i_max
    re_n = np.broadcast_to(
        np.real(np.asarray(model.describing_function(small, f, **kw))), small.shape
    )
    l0, l1 = float(re_n[0]), float(re_n[1])
    change = 0.0 if l0 == l1 else (abs(l1 - l0) / abs(l0) if l0 != 0 else math.inf)

    l_max, a_at_max = _maximum_amplitude_inductance(model, i_max, f, kw)
    marks = loop_landmarks(model, [i_max], f, **kw)
    tip, residual, hc = (
        float(marks["tip"][0]),
        float(marks["residual"][0]),
        float(marks["coercive"][0]),
    )

    if series_resistance is None:
        series_resistance = theta.get("r_series") if hasattr(theta, "get") else None
    if winding_resistance_estimate is None:
        winding_resistance_estimate = geometry.r_winding_estimate
    nan = float("nan")
    return MaterialConstants(
        model=_model_name(model),
        frequency_hz=f,
        current_max_a=i_max,
        initial_inductance_h=l0,
        initial_permeability=float(geometry.relative_permeability(l0)),
        initial_relative_change=float(change),
        initial_converged=bool(change <= _CONVERGENCE_TOL),
        maximum_inductance_h=l_max,
        maximum_permeability=float(geometry.relative_permeability(l_max)),
        maximum_amplitude_a=a_at_max,
        maximum_at_edge=bool(a_at_max >= i_max * (1.0 - 1e-9)),
        coercive_current_a=hc,
        coercive_force_a_per_m=float(geometry.field(hc)),
        coercive_force_oe=float(geometry.field_oe(hc)),
        peak_flux_linkage_vs=tip,
        peak_flux_density_t=float(geometry.induction(tip)),
        peak_flux_density_gauss=float(geometry.induction_gauss(tip)),
        residual_flux_linkage_vs=residual,
        residual_induction_t=float(geometry.induction(residual)),
        residual_induction_gauss=float(geometry.induction_gauss(residual)),
        squareness=residual / tip if tip != 0 else nan,
        series_resistance_ohm=nan if series_resistance is None else float(series_resistance),
        winding_resistance_estimate_ohm=nan
        if winding_resistance_estimate is None
        else float(winding_resistance_estimate),
        geometry=geometry,
    )


def implied_stacking_factor(constants, ranges) -> dict | None:
    """The stacking factors at which the fitted peak flux linkage lies in the Appendix A
    ``B_p`` range: ``{"low", "high", "range", "consistent"}``; ``consistent`` says whether it
    overlaps the geometry's stacking range. None without a stacking factor or a ``B_p``
    range, or when the fit has no peak flux.

    ``lambda_p / (N A_gross B_p)`` over the printed ``B_p`` range: the DF data determine the
    peak flux linkage (it is invariant under the current scale), so this is what the data
    and Appendix A together say of the iron fraction.
    """
    geometry = constants.geometry
    bp = ranges.get("peak_flux_density_Bp")
    lam = constants.peak_flux_linkage_vs
    if bp is None or geometry.stacking_factor is None or not (math.isfinite(lam) and lam > 0):
        return None
    low_b, high_b = (float(v) / 1e4 if v is not None else math.inf for v in bp[:2])  # gauss -> T
    low = float(geometry.stacking_factor_for_induction(lam, high_b))
    high = float(geometry.stacking_factor_for_induction(lam, low_b))
    allowed = geometry.stacking_range or (geometry.stacking_factor, geometry.stacking_factor)
    return {
        "low": low,
        "high": high,
        "range": [float(allowed[0]), float(allowed[1])],
        "consistent": bool(low <= allowed[1] and high >= allowed[0]),
    }


def appendix_a_check(constants, ranges, *, joint=False) -> list[dict]:
    """Compare fitted material constants with the Appendix A ranges.

    Parameters
    ----------
    constants : MaterialConstants or mapping
        A :class:`MaterialConstants`, or a mapping ``quantity -> value`` in Appendix A
        units (as :meth:`MaterialConstants.appendix_a_values` returns).
    ranges : mapping
        ``quantity -> (low, high, unit)`` as :func:`fitdf.data.cores.appendix_a_ranges`
        returns (``high`` None: no upper limit). A ``"series_resistance"`` entry, if
        present, overrides the band built from the estimate.
    joint : bool
        The fit's data span two source impedances, which fixes the current scale.

    Returns
    -------
    list of dict
        One ``{quantity, fitted, low, high, unit, inside, fitted_low, fitted_high,
        inside_range, determined}`` per quantity of :data:`CHECK_QUANTITIES` that ``ranges``
        covers, in that order; ``fitted``, ``low`` are plain floats (``fitted`` NaN where the
        loop does not define it, e.g. no coercive force), ``high`` a float or None,
        ``inside`` a bool: ``low <= fitted <= high`` with both edges included, False for
        NaN. ``fitted_low``/``fitted_high`` span the value over the geometry's stacking
        range (equal to ``fitted`` for the constants that do not depend on it, and for a
        mapping without a geometry), ``inside_range`` whether that span meets the Appendix A
        range, and ``determined`` says what fixes the value (:data:`DETERMINED_BY`). The
        ``series_resistance`` row appears only when both a fitted value and an estimate (or
        range) are known.
    """
    values = (
        constants.appendix_a_values()
        if hasattr(constants, "appendix_a_values")
        else dict(constants)
    )
    geometry = getattr(constants, "geometry", None)
    spread = (1.0, 1.0) if geometry is None else geometry.iron_fraction_spread
    ranges = dict(ranges)
    if "series_resistance" not in ranges:
        est = values.get("winding_resistance_estimate")
        if est is not None and math.isfinite(float(est)):
            median, sigma = series_resistance_prior(float(est))
            width = math.exp(RESISTANCE_PRIOR_SIGMAS * sigma)
            ranges["series_resistance"] = (median / width, median * width, "ohm")
    rows = []
    for quantity in CHECK_QUANTITIES:
        if quantity not in ranges:
            continue
        fitted = values.get(quantity)
        fitted = float("nan") if fitted is None else float(fitted)
        if quantity == "series_resistance" and not math.isfinite(fitted):
            continue
        low, high, unit = ranges[quantity]
        low = float(low)
        high = None if high is None or not math.isfinite(float(high)) else float(high)
        inside = bool(math.isfinite(fitted) and low <= fitted and (high is None or fitted <= high))
        f_low, f_high = (fitted * m for m in spread) if _DEPENDS[quantity][0] else (fitted,) * 2
        meets = bool(math.isfinite(fitted) and f_high >= low and (high is None or f_low <= high))
        rows.append(
            {
                "quantity": quantity,
                "fitted": fitted,
                "low": low,
                "high": high,
                "unit": str(unit),
                "inside": inside,
                "fitted_low": f_low,
                "fitted_high": f_high,
                "inside_range": meets,
                "determined": _determined(quantity, joint),
            }
        )
    return rows


# --- material units -> winding units (for bounds in material units), and back -----------------


def inductance_from_permeability(mu_r, geometry: CoreGeometry):
    """Winding inductance (H) of a relative permeability (gauss/oersted): ``mu_0 mu_r N^2 A_e / l_e``."""
    return _float(geometry.inductance(mu_r))


def permeability_from_inductance(inductance, geometry: CoreGeometry):
    """Relative permeability (gauss/oersted) of a winding inductance (H)."""
    return _float(geometry.relative_permeability(inductance))


def current_from_field(h_oe, geometry: CoreGeometry):
    """Winding current (A) producing the field ``h_oe`` (oersted): ``H l_e / N``."""
    return _float(geometry.current_oe(h_oe))


def field_from_current(current, geometry: CoreGeometry):
    """Field (oersted) of a winding current (A)."""
    return _float(geometry.field_oe(current))


def flux_linkage_from_induction(b_gauss, geometry: CoreGeometry):
    """Flux linkage (V s) of an induction ``b_gauss`` (gauss): ``B N A_e``."""
    return _float(geometry.flux_linkage_gauss(b_gauss))


def induction_from_flux_linkage(flux_linkage, geometry: CoreGeometry):
    """Induction (gauss) of a flux linkage (V s)."""
    return _float(geometry.induction_gauss(flux_linkage))


def material_record(result) -> MaterialRecord | None:
    """Material constants of a fit and, for an Appendix A core, their check (a JSON-ready
    dict that also presents itself, :class:`~fitdf.inference.presentation.MaterialRecord`).

    None when the fit has no core geometry or its chain is not in winding units (the
    check is then absent, not invented). ``current_max`` is the largest peak winding
    current the fitted chain predicts at the data points; a frequency-dependent law is
    evaluated at the lowest data frequency. ``constants`` carries, besides
    :meth:`MaterialConstants.to_dict`, the ``implied_stacking_factor``
    (:func:`implied_stacking_factor`, None without Appendix A ranges); the check says what
    the data determine, with ``joint`` when the rows span two source impedances.
    ``undetermined`` names the fitted parameters the constants rest on that the data do not
    determine (:func:`~fitdf.inference.caveats.undetermined_parameters`; the calibration
    gains, which no constant uses, left out), and ``caveat`` says so in a sentence (None when
    there are none).
    """
    problem = result.problem
    geometry = problem.geometry
    if geometry is None or not problem.chain.winding_units:
        return None
    data = problem.data
    currents = problem.core_currents(result.internal)
    constants = material_constants(
        problem.model,
        result.values,
        geometry,
        current_max=float(np.nanmax(currents)),
        frequency=float(np.min(data.frequency)),
        series_resistance=result.values.get("r_series"),
        winding_resistance_estimate=geometry.r_winding_estimate,
    )
    try:
        ranges = appendix_a_ranges(data.core) if data.core else None
    except OptionError:  # a user's core: no catalogue ranges to compare with
        ranges = None
    joint = np.unique(np.asarray(data.source_impedance, float)).size > 1
    implied = None if ranges is None else implied_stacking_factor(constants, ranges)
    loose = [
        name
        for name in undetermined_parameters(problem, result.intervals, result.internal)
        if parameter_base(name) not in PER_TABLE
    ]
    record = clean(
        {
            "core": data.core,
            "constants": {**constants.to_dict(), "implied_stacking_factor": implied},
            "appendix_a_check": None
            if ranges is None
            else appendix_a_check(constants, ranges, joint=joint),
            "undetermined": loose,
            "caveat": _caveat(loose),
        }
    )
    return MaterialRecord(record)


def _caveat(loose) -> str | None:
    """The sentence for constants computed from parameters the data leave open."""
    if not loose:
        return None
    which = ", ".join(loose)
    return (
        f"the data do not determine {which} (on a bound, or a 68 % interval over a decade "
        f"wide): the constants computed from {'it' if len(loose) == 1 else 'them'} are as "
        "open"
    )


def with_material(result):
    """``result`` with its :func:`material_record` attached (results are immutable)."""
    return replace(result, material=material_record(result))

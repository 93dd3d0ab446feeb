"""Tables 5.1/5.2 predicted from the Appendix B fits: unscaled, with held-out scales, and in time.

:func:`thesis_limit_cycle_comparison` predicts every row of the analog-computer tables by
harmonic balance (:mod:`fitdf.loop.harmonic`) with the fitted core of the matching Appendix B
table, in *settings* that differ only in the computer's unprinted scalings
(:mod:`fitdf.limit_cycle_tables.scales`):

``unscaled``
    ``alpha = beta = 1``: the plant as printed, the system gain as the loop gain. Nothing is
    fitted to Tables 5.1/5.2: this is the prediction.
``held_out``
    per block, the ``(alpha, beta)`` fitted on the other three blocks (leave one block out):
    the scales are fitted on some rows and judged on others.
``given``
    the scales the caller gives, when it gives any.

Optionally every row is also simulated in time with the same fitted core
(:mod:`fitdf.loop.simulate`), so that the describing-function approximation (harmonic
balance against the simulation) and the rest (the simulation against the table: the law,
the loop's assumptions, the scales) are told apart.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitdf._json import clean
from fitdf.data import datasets
from fitdf.inference.api import fit
from fitdf.inference.ranking import best_by_aicc
from fitdf.limit_cycle_tables import summary
from fitdf.limit_cycle_tables.data_bound import data_implied_critical_gains
from fitdf.limit_cycle_tables.scales import (
    THESIS_BLOCKS,
    THESIS_PLANT,
    estimate_thesis_scales,
    held_out_scales,
    per_block_scales,
)
from fitdf.limit_cycle_tables.statements import limit_cycle_statements
from fitdf.loop.elements import CoreElement
from fitdf.loop.harmonic import limit_cycles
from fitdf.loop.simulate import simulate_loop
from fitdf.models import model_names

__all__ = [
    "thesis_limit_cycle_comparison",
    "SIM_PERIODS",
    "SIM_STEPS_PER_PERIOD",
    "SIM_DRIFT_TOL",
    "OMEGA_RANGE",
]

#: Periods of the slowest start frequency each simulated block runs; the last 40 % of the
#: record are measured. Started on the predicted cycle (``initial_omega``), the report's loops
#: (Preisach, B.5 and B.2, both settings) measure the same cycles at 25, 40 and 80 periods to
#: 0.14 % in amplitude and 0.18 % in frequency.
SIM_PERIODS = 25
#: Steps per period of the fastest start frequency: against 400, the cycles move by 0.13 % in
#: amplitude and 0.06 % in frequency at 200, by 0.8 % and 0.4 % at 100 -- the former well
#: below the describing-function approximation the simulation measures (about 2 % and 1 %).
SIM_STEPS_PER_PERIOD = 200
#: Angular frequencies (rad/s) harmonic balance searches in every setting: the default box of
#: :func:`~fitdf.loop.harmonic.limit_cycles` (the plant's corners / 30 and x 30) for time
#: scales from 1 to 2.5, around the tables' 9-27 rad/s with a wide margin; fixed, so that
#: each block's grid of ``N`` is evaluated once for all settings (:class:`_GridKeptDF`).
OMEGA_RANGE = (0.03, 300.0)
#: Evaluations of ``N`` at least this large are kept (the grid; the refinement's are small).
GRID_POINTS = 10_000
#: A simulated oscillation whose peak-to-peak changes by more than this fraction between the
#: first and last measured cycles has not settled: its amplitude is not reported.
SIM_DRIFT_TOL = 0.01


def _fit_best(data, models, seed, n_starts):
    """The lowest-AICc least-squares fit among ``models`` (all registered when None)."""
    names = [models] if isinstance(models, str) else list(models or model_names())
    return best_by_aicc([fit(data, m, seed=seed, n_starts=n_starts) for m in names])


class _GridKeptDF:
    """A fitted core's ``N(A, omega)`` at one source impedance (as
    :func:`~fitdf.loop.nonlinearity.as_describing_function` makes it) that keeps its last
    evaluation of at least :data:`GRID_POINTS` points: harmonic balance evaluates the same
    grid in every setting, and that grid is ~90 % of its cost."""

    def __init__(self, fit_, source_impedance):
        self.fit, self.rs = fit_, float(source_impedance)
        self.__name__ = f"{fit_.model} at {self.rs:g} ohm"
        self._key, self._value = None, None

    def __call__(self, A, omega):
        A, omega = np.broadcast_arrays(np.asarray(A, float), np.asarray(omega, float))
        key = (A.shape, A.tobytes(), omega.tobytes())
        if key == self._key:
            return self._value
        out = self.fit.predict(A, omega / (2.0 * np.pi), self.rs)
        if A.size >= GRID_POINTS:
            self._key, self._value = key, out
        return out


def _load_tables():
    table = pd.concat([datasets.load("table_5_1"), datasets.load("table_5_2")], ignore_index=True)
    table["source_impedance_ohm"] = table["source_impedance_ohm"].astype(float)
    return table


def _predict_block(block, fit_, N, alpha, beta, amplitude_range):
    """Harmonic balance at every gain of one block (``N``: the core's DF there): the largest
    stable cycle per row, the critical gain (system-gain units) and the critical point's
    frequency."""
    resp = limit_cycles(
        THESIS_PLANT,
        N,
        beta * block["system_gain"].to_numpy(float),
        amplitude_range=amplitude_range,
        omega_range=OMEGA_RANGE,
        time_scale=alpha,
    )
    pred = resp.stable_cycles()
    d = fit_.problem.data
    amp_box, f_box = (d.amplitude.min(), d.amplitude.max()), (d.frequency.min(), d.frequency.max())
    fa, fw = pred["amplitude"].to_numpy(float), pred["omega_rad_s"].to_numpy(float)
    inside = (amp_box[0] <= fa) & (fa <= amp_box[1])
    inside &= (f_box[0] <= fw / (2 * np.pi)) & (fw / (2 * np.pi) <= f_box[1])
    out = block.copy()
    out["alpha"], out["beta"] = alpha, beta
    out["amplitude_pred"], out["omega_pred"] = fa, fw
    out["amplitude_ratio"] = fa / block["amplitude_v"].to_numpy(float)
    out["omega_ratio"] = fw / block["omega_rad_s"].to_numpy(float)
    out["n_stable"] = pred["n_stable"].to_numpy(int)
    out["critical_gain_pred"] = resp.critical_gain / beta
    out["critical_omega_pred"] = float(resp.critical_point.get("omega", np.nan))
    out["extrapolated"] = np.isfinite(fa) & ~inside
    return out, out["critical_omega_pred"].iloc[0]


def _simulate_block(block, fit_, rs, critical_omega):
    """The loop in time at every row of one block and setting (one batch), each member started
    on the sinusoid of its predicted cycle (``simulate_loop(initial_omega=...)``); a row
    without one starts at its measured amplitude (else 1 V) and the critical point's
    frequency (else the measured one). ``sim_state`` is ``oscillates`` (settled within
    :data:`SIM_DRIFT_TOL`), ``dies out`` or ``unsettled``."""
    alpha, beta = float(block["alpha"].iloc[0]), float(block["beta"].iloc[0])
    a0 = block["amplitude_pred"].fillna(block["amplitude_v"]).fillna(1.0).to_numpy(float)
    w0 = block["omega_pred"].fillna(critical_omega if np.isfinite(critical_omega) else np.nan)
    w0 = w0.fillna(block["omega_rad_s"]).fillna(1.0 / alpha).to_numpy(float)
    sim = simulate_loop(
        THESIS_PLANT,
        CoreElement.from_fit(fit_, rs),
        beta * block["system_gain"].to_numpy(float),
        time_scale=alpha,
        dt=2 * np.pi / w0.max() / SIM_STEPS_PER_PERIOD,
        t_end=SIM_PERIODS * 2 * np.pi / w0.min(),
        initial_output=a0,
        initial_omega=w0,
    ).measure()
    osc = sim["oscillating"].to_numpy(bool)
    settled = osc & (np.abs(sim["drift"].to_numpy(float)) <= SIM_DRIFT_TOL)
    out = block.copy()
    out["sim_state"] = np.where(settled, "oscillates", np.where(osc, "unsettled", "dies out"))
    out["amplitude_sim"] = np.where(settled, sim["amplitude_h1"], np.nan)
    out["amplitude_peak_sim"] = np.where(settled, sim["amplitude"], np.nan)
    out["omega_sim"] = np.where(settled, sim["omega"], np.nan)
    out["sim_drift"] = sim["drift"].to_numpy(float)
    return out


def thesis_limit_cycle_comparison(
    seed=0,
    models=None,
    *,
    time_scale=None,
    gain_scale=None,
    amplitude_range=(0.01, 20.0),
    n_starts=6,
    time_domain=False,
    candidates=None,
) -> pd.DataFrame:
    """Predict the analog-computer limit cycles of Tables 5.1/5.2 from the Appendix B fits.

    Each (core, source impedance) block is predicted from the table measured on that core at
    that impedance (:data:`~fitdf.limit_cycle_tables.THESIS_BLOCKS`: Permalloy B.1 / B.3, Deltamax B.2 /
    B.5), with the lowest-AICc model among ``models`` (all registered models when None; a
    list compares per block, a single name forces it), fitted by least squares through the
    default (exact ``voltage``) chain with ``seed`` and ``n_starts``. Fits made already can be
    handed in instead: ``candidates`` maps a table name (``"B.1"``...) to its candidate fits,
    of which the lowest-AICc is used (``models``, ``seed`` and ``n_starts`` are then not used
    for that table); the report passes its own.

    Assumptions (the thesis states neither where the amplitude was read nor the computer's
    scaling):

    * the loop is Fig 5.12 -- error -> core -> ``G`` -> output, unity feedback -- and the
      tabulated amplitude is the core's input voltage (= the plant output);
    * the core's DF in the loop is the one measured in Appendix B (volts out over volts in
      through the table's source impedance);
    * the analog computer may have run the plant ``alpha`` times faster than written,
      ``G(s / alpha)`` (the core is real hardware, so its frequencies are physical), and its
      loop gain may be ``beta`` times the "system gain".

    Each row is predicted in every *setting* of the scales: ``unscaled`` (``alpha = beta =
    1``, nothing fitted to Tables 5.1/5.2), ``held_out`` (per block, the scales
    :func:`~fitdf.limit_cycle_tables.estimate_thesis_scales` fits on the other three blocks) and, when
    ``time_scale`` or ``gain_scale`` is given, ``given`` (the one not given is 1).

    Parameters
    ----------
    seed, models, n_starts, candidates
        The fits (above).
    time_scale, gain_scale : float, optional
        Scales of the ``given`` setting.
    amplitude_range : (float, float)
        Amplitudes (V) harmonic balance searches.
    time_domain : bool
        Also simulate the loop in time at every row and setting with the fitted core's loop
        operator (:class:`~fitdf.loop.elements.CoreElement`), started on the predicted cycle
        (:data:`SIM_PERIODS` periods, :data:`SIM_STEPS_PER_PERIOD` steps per period).

    Returns
    -------
    pandas.DataFrame
        One row per table row and setting: ``setting``, ``core``, ``source_impedance_ohm``,
        ``table``, ``model``, the setting's ``alpha`` and ``beta``, ``system_gain``, measured
        ``amplitude_v`` / ``omega_rad_s`` / ``dies_out``, predicted ``amplitude_pred`` /
        ``omega_pred`` (the largest stable cycle; NaN when harmonic balance finds none),
        ``amplitude_ratio`` / ``omega_ratio`` (predicted over measured), ``n_stable``, the
        block's ``critical_gain_pred`` (system-gain units) and ``extrapolated`` (the
        predicted cycle lies outside the amplitudes or frequencies the fit saw). With
        ``time_domain=True`` also ``sim_state`` (``oscillates``, ``dies out`` or
        ``unsettled``), ``amplitude_sim`` (first harmonic at the core's input),
        ``amplitude_peak_sim`` (half the peak-to-peak), ``omega_sim`` and ``sim_drift``.

        ``attrs`` (the report's record): ``plant``; ``scales`` -- ``per_block`` (each
        block's own scales, in-sample), ``held_out`` (per block, fitted on the others, with
        ``fitted_on``), ``joint`` (one pair on all rows, in-sample), ``spread`` (the range
        of the per-block values) and ``given``; ``agreement``, ``trends``,
        ``impedance_order``, ``critical_gains``, ``dies_out_rows`` and ``time_domain``
        (:mod:`fitdf.limit_cycle_tables.summary`, each per setting); ``statements`` (the sentences of
        :func:`~fitdf.limit_cycle_tables.limit_cycle_statements`, made from those fields); ``fits``.
    """
    table = _load_tables()
    fits = {
        key: best_by_aicc(candidates[name])
        if candidates is not None and candidates.get(name)
        else _fit_best(name, models, seed, n_starts)
        for key, name in THESIS_BLOCKS.items()
    }
    osc = table[
        np.isfinite(table["omega_rad_s"]) & np.isfinite(table["amplitude_v"]) & ~table["dies_out"]
    ]
    held = held_out_scales(osc, fits)
    scales, given = _settings_scales(held, time_scale, gain_scale)
    df = _predicted_rows(table, fits, scales, amplitude_range, time_domain)
    df.attrs.update(clean(_record(df, osc, fits, held, given)))
    df.attrs["statements"] = limit_cycle_statements(df.attrs)
    return df


def _settings_scales(held, time_scale, gain_scale):
    """Each setting's ``(alpha, beta)`` by table (``unscaled``, ``held_out`` and, with a scale
    given, ``given``), and the given scales' record (None without)."""
    scales = {
        "unscaled": {name: (1.0, 1.0) for name in THESIS_BLOCKS.values()},
        "held_out": {name: (h["alpha"], h["beta"]) for name, h in held.items()},
    }
    given = None
    if time_scale is not None or gain_scale is not None:
        given = {
            "alpha": float(time_scale) if time_scale is not None else 1.0,
            "beta": float(gain_scale) if gain_scale is not None else 1.0,
        }
        scales["given"] = {name: (given["alpha"], given["beta"]) for name in THESIS_BLOCKS.values()}
    return scales, given


def _predicted_rows(table, fits, scales, amplitude_range, time_domain) -> pd.DataFrame:
    """Every table row predicted in every setting (:func:`thesis_limit_cycle_comparison`'s
    frame, without its ``attrs``)."""
    parts = []
    dfs = {key: _GridKeptDF(f, key[1]) for key, f in fits.items()}
    for setting, per_block in scales.items():
        for (core, rs), block in table.groupby(["core", "source_impedance_ohm"], sort=False):
            name = THESIS_BLOCKS[(core, rs)]
            f = fits[(core, rs)]
            block = block.assign(setting=setting, table=name, model=f.model)
            pred, w_crit = _predict_block(
                block, f, dfs[(core, rs)], *per_block[name], amplitude_range
            )
            if time_domain:
                pred = _simulate_block(pred, f, rs, w_crit)
            parts.append(pred)
    df = pd.concat(parts, ignore_index=True)
    lead = [
        "setting",
        "core",
        "source_impedance_ohm",
        "table",
        "model",
        "alpha",
        "beta",
        "system_gain",
        "amplitude_v",
        "omega_rad_s",
        "dies_out",
    ]
    return df[lead + [c for c in df.columns if c not in lead + ["frequency_hz", "source"]]]


def _record(df, osc, fits, held, given) -> dict:
    """The comparison's ``attrs`` but the statements: the plant, the scales, the summaries of
    :mod:`fitdf.limit_cycle_tables.summary` and the fits."""
    per_block = per_block_scales(osc, fits)
    values = {k: [s[k] for s in per_block.values()] for k in ("alpha", "beta")}
    return {
        "plant": THESIS_PLANT,
        "scales": {
            "per_block": per_block,
            "held_out": held,
            "joint": estimate_thesis_scales(osc, fits),
            "spread": {
                f"{k}_{end}": fn(v)
                for k, v in values.items()
                for end, fn in (("min", min), ("max", max))
            },
            "given": given,
        },
        **summary.summarise(df),
        "data_implied": {
            THESIS_BLOCKS[k]: data_implied_critical_gains(f.problem.data, THESIS_PLANT)
            for k, f in fits.items()
        },
        "fits": {
            THESIS_BLOCKS[k]: {
                "model": f.model,
                "values": dict(f.values),
                "rms_complex": f.metrics["rms_complex"],
            }
            for k, f in fits.items()
        },
    }

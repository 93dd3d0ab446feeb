"""The thesis's own comparisons: the analog-computer limit cycles of Tables 5.1 and 5.2 (section V.6).

The loop of Fig 5.12 (error -> core -> amplidyne/generator plant -> output) was run on an
analog computer with the cores of Appendix B; Tables 5.1 (Permalloy) and 5.2 (Deltamax)
list the limit cycles seen at each system gain. :func:`thesis_limit_cycle_comparison`
predicts them by harmonic balance (:mod:`fitdf.loop.harmonic`) from the fits of the
matching Appendix B tables, after estimating the computer's unprinted time and gain
scalings (:func:`estimate_thesis_scales`), and optionally checks the prediction by
simulating the loop in time (:mod:`fitdf.loop.simulate`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.optimize import minimize_scalar

from fitdf._json import clean
from fitdf.data import datasets
from fitdf.errors import OptionError
from fitdf.inference.api import fit
from fitdf.inference.ranking import best_by_aicc
from fitdf.loop.elements import CoreElement
from fitdf.loop.harmonic import limit_cycles
from fitdf.loop.plant import as_loop_plant
from fitdf.loop.simulate import simulate_loop
from fitdf.models import model_names

__all__ = [
    "thesis_limit_cycle_comparison",
    "estimate_thesis_scales",
    "THESIS_PLANT",
    "THESIS_BLOCKS",
]

#: The plant of the analog-computer study (thesis V.6): amplidyne + generator.
THESIS_PLANT = "K/((1+s)(1+0.25s)(1+1.1s))"
#: Appendix B table fitted for each (core, source impedance) block of Tables 5.1/5.2.
THESIS_BLOCKS = {
    ("permalloy", 0.0): "B.1",
    ("permalloy", 600.0): "B.3",
    ("deltamax", 0.0): "B.2",
    ("deltamax", 600.0): "B.5",
}


def _fit_best(data, models, seed, n_starts):
    """The lowest-AICc least-squares fit among ``models`` (all registered when None)."""
    names = [models] if isinstance(models, str) else list(models or model_names())
    return best_by_aicc([fit(data, m, seed=seed, n_starts=n_starts) for m in names])


def _balance_terms(rows, fits):
    """``K N(A, omega)`` at the measured cycles (independent of the scalings) and ``omega``."""
    KN, omega = [], []
    keep = np.isfinite(rows[["system_gain", "amplitude_v", "omega_rad_s"]].to_numpy(float)).all(
        axis=1
    )
    if not keep.any():
        raise OptionError("no measured cycle with a finite gain, amplitude and frequency")
    for key, block in rows[keep].groupby(
        ["core", "source_impedance_ohm"]
    ):  # per block, vectorised in rows
        w = block["omega_rad_s"].to_numpy(float)
        N = fits[key].predict(block["amplitude_v"].to_numpy(float), w / (2 * np.pi), key[1])
        KN.append(block["system_gain"].to_numpy(float) * N)
        omega.append(w)
    return np.concatenate(KN), np.concatenate(omega)


def estimate_thesis_scales(rows, fits) -> dict:
    """Time scale ``alpha`` and gain scale ``beta`` from harmonic balance at the measured cycles.

    At a measured cycle ``(K, A, omega)`` harmonic balance requires
    ``beta K G0(j omega / alpha) N(A, omega) = -1``. Its phase involves ``alpha`` only:
    ``alpha`` minimises the squared phase residuals (grid in ``ln alpha`` over
    ``[0.1, 100]``, then a bounded 1-D polish); ``ln beta`` is then the mean of
    ``-ln |K G0 N|``. Returns ``alpha``, ``beta`` and the RMS residuals left
    (phase in degrees, magnitude as a factor).
    """
    lp = as_loop_plant(THESIS_PLANT)
    KN, omega = _balance_terms(rows, fits)

    def residuals(la):
        H = KN * lp.response(omega / np.exp(la), [1.0])[0]
        return np.angle(-H), np.log(np.abs(H))

    def cost(la):
        return float(np.mean(residuals(la)[0] ** 2))

    grid = np.linspace(np.log(0.1), np.log(100.0), 121)
    k = int(np.argmin([cost(la) for la in grid]))  # the phase cost may be multimodal
    res = minimize_scalar(
        cost,
        bounds=(grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]),
        method="bounded",
        options={"xatol": 1e-9},
    )
    ph, lm = residuals(res.x)
    log_beta = -float(np.mean(lm))
    return {
        "alpha": float(np.exp(res.x)),
        "beta": float(np.exp(log_beta)),
        "rms_phase_deg": float(np.degrees(np.sqrt(np.mean(ph**2)))),
        "rms_magnitude_factor": float(np.exp(np.sqrt(np.mean((lm + log_beta) ** 2)))),
        "n_rows": int(ph.size),
    }


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

    Each (core, source impedance) block is predicted from the table measured on that
    core at that impedance (:data:`THESIS_BLOCKS`: Permalloy B.1 / B.3, Deltamax
    B.2 / B.5), with the lowest-AICc model among ``models`` (all registered models when
    None; a list compares per block, a single name forces it), fitted by least squares
    through the default (exact ``voltage``) chain with ``seed`` and ``n_starts``. Fits
    made already can be handed in instead: ``candidates`` maps a table name (``"B.1"``...) to
    its candidate fits, of which the lowest-AICc is used (``models``, ``seed`` and
    ``n_starts`` are then not used for that table); the report passes its own.

    Assumptions (the thesis states neither where the amplitude was read nor the
    computer's scaling):

    * the loop is Fig 5.12 -- error -> core -> ``G`` -> output, unity feedback -- and
      the tabulated amplitude is the core's input voltage (= the plant output);
    * the core's DF in the loop is the one measured in Appendix B (volts out over volts
      in through the table's source impedance);
    * the analog computer ran the plant ``alpha`` times faster than written,
      ``G(s / alpha)`` (the core is real hardware, so its frequencies are physical), and
      the loop gain is ``beta`` times the "system gain" -- one ``alpha`` and one ``beta``
      for all rows of both tables. Unless given, both are estimated from the tables
      (:func:`estimate_thesis_scales`); ``df.attrs["scales"]`` also holds the per-block
      estimates, which show whether one pair fits all blocks.

    Returns
    -------
    pandas.DataFrame
        One row per table row: ``core``, ``source_impedance_ohm``, ``table``, ``model``,
        ``system_gain``, measured ``amplitude_v`` / ``omega_rad_s`` / ``dies_out``,
        predicted ``amplitude_pred`` / ``omega_pred`` (the largest stable cycle at
        ``beta K``), their ratios, ``n_stable``, the predicted ``critical_gain_pred`` of
        the block (system-gain units) and ``extrapolated`` (the predicted cycle lies
        outside the amplitudes or frequencies the fit saw). With ``time_domain=True``
        also ``amplitude_sim`` / ``omega_sim`` / ``oscillating_sim``: the loop simulated
        with the fitted core's loop operator (:mod:`fitdf.loop.simulate`), started at the
        measured amplitude. ``attrs`` holds ``alpha``, ``beta``, ``scales`` (joint and
        per-block estimates), ``agreement`` (RMS log ratios per block) and the fits.
    """
    table = pd.concat([datasets.load("table_5_1"), datasets.load("table_5_2")], ignore_index=True)
    table["source_impedance_ohm"] = table["source_impedance_ohm"].astype(float)
    fits = {
        key: best_by_aicc(candidates[name])
        if candidates is not None and candidates.get(name)
        else _fit_best(name, models, seed, n_starts)
        for key, name in THESIS_BLOCKS.items()
    }
    osc = table[
        np.isfinite(table["omega_rad_s"]) & np.isfinite(table["amplitude_v"]) & ~table["dies_out"]
    ]
    joint = estimate_thesis_scales(osc, fits)
    per_block = {
        f"{c} {r:g} ohm": estimate_thesis_scales(b, fits)
        for (c, r), b in osc.groupby(["core", "source_impedance_ohm"])
    }
    alpha = float(time_scale) if time_scale is not None else joint["alpha"]
    beta = float(gain_scale) if gain_scale is not None else joint["beta"]
    out = []
    for (core, rs), block in table.groupby(["core", "source_impedance_ohm"], sort=False):
        f = fits[(core, rs)]
        gains = block["system_gain"].to_numpy(float)
        resp = limit_cycles(
            THESIS_PLANT,
            f,
            beta * gains,
            source_impedance=rs,
            amplitude_range=amplitude_range,
            time_scale=alpha,
        )
        pred = resp.stable_cycles()
        d = f.problem.data
        amp_box, f_box = (
            (d.amplitude.min(), d.amplitude.max()),
            (d.frequency.min(), d.frequency.max()),
        )
        for (_, row), (_, p) in zip(block.iterrows(), pred.iterrows()):
            fa, fw = p["amplitude"], p["omega_rad_s"]
            out.append(
                {
                    "core": core,
                    "source_impedance_ohm": rs,
                    "table": THESIS_BLOCKS[(core, rs)],
                    "model": f.model,
                    "system_gain": row["system_gain"],
                    "amplitude_v": row["amplitude_v"],
                    "omega_rad_s": row["omega_rad_s"],
                    "dies_out": bool(row["dies_out"]),
                    "amplitude_pred": fa,
                    "omega_pred": fw,
                    "amplitude_ratio": fa / row["amplitude_v"],
                    "omega_ratio": fw / row["omega_rad_s"],
                    "n_stable": int(p["n_stable"]),
                    "critical_gain_pred": resp.critical_gain / beta,
                    "extrapolated": bool(
                        np.isfinite(fa)
                        and not (
                            amp_box[0] <= fa <= amp_box[1]
                            and f_box[0] <= fw / (2 * np.pi) <= f_box[1]
                        )
                    ),
                }
            )
    df = pd.DataFrame(out)
    if time_domain:
        df = _add_time_domain(df, fits, alpha, beta)
    df.attrs.update(
        {
            "alpha": alpha,
            "beta": beta,
            "plant": THESIS_PLANT,
            "agreement": _agreement(df),
            "critical_gains": _critical_summary(df),
            "scales": {"joint": joint, **per_block},
            "fits": {
                THESIS_BLOCKS[k]: {
                    "model": f.model,
                    "values": dict(f.values),
                    "rms_complex": f.metrics["rms_complex"],
                }
                for k, f in fits.items()
            },
        }
    )
    return df


def _agreement(df) -> dict:
    """RMS of ln(predicted / measured) for amplitude and frequency, per block and overall."""
    out = {}
    for key, g in [("all", df)] + [
        (f"{c} {r:g} ohm", g) for (c, r), g in df.groupby(["core", "source_impedance_ohm"])
    ]:
        ok = ~g["dies_out"] & g["amplitude_ratio"].notna()
        out[key] = {
            "rms_log_amplitude_ratio": float(
                np.sqrt(np.mean(np.log(g.loc[ok, "amplitude_ratio"]) ** 2))
            )
            if ok.any()
            else float("nan"),
            "rms_log_omega_ratio": float(np.sqrt(np.mean(np.log(g.loc[ok, "omega_ratio"]) ** 2)))
            if ok.any()
            else float("nan"),
            "rows_predicted": int(ok.sum()),
            "rows_oscillating": int((~g["dies_out"]).sum()),
        }
    return out


def _critical_summary(df) -> list:
    """Per block: the measured die-out gain, the smallest gain that oscillated, and the prediction."""
    rows = []
    for (core, rs), g in df.groupby(["core", "source_impedance_ohm"], sort=False):
        dead, live = g[g["dies_out"]], g[~g["dies_out"]]
        rows.append(
            {
                "core": core,
                "source_impedance_ohm": rs,
                "table": g["table"].iloc[0],
                "measured_dies_out_at": float(dead["system_gain"].max())
                if not dead.empty
                else None,
                "measured_lowest_oscillating": float(live["system_gain"].min())
                if not live.empty
                else None,
                "predicted_critical_gain": clean(float(g["critical_gain_pred"].iloc[0])),
            }
        )
    return rows


def _add_time_domain(df, fits, alpha, beta, steps_per_period=200, periods=40):
    """Simulate every row's loop (one batch per block) with the fitted core's loop operator."""
    parts = []
    for (core, rs), block in df.groupby(["core", "source_impedance_ohm"], sort=False):
        el = CoreElement.from_fit(fits[(core, rs)], rs)
        w = np.concatenate(
            [block["omega_pred"].to_numpy(float), block["omega_rad_s"].to_numpy(float)]
        )
        w = w[np.isfinite(w)]
        a0 = block["amplitude_v"].fillna(block["amplitude_pred"]).fillna(0.5).to_numpy(float)
        sim = simulate_loop(
            THESIS_PLANT,
            el,
            beta * block["system_gain"].to_numpy(float),
            time_scale=alpha,
            dt=2 * np.pi / w.max() / steps_per_period,
            t_end=periods * 2 * np.pi / w.min(),
            initial_output=a0,
        ).measure()
        block = block.copy()
        block["amplitude_sim"] = np.where(sim["oscillating"], sim["amplitude_h1"], np.nan)
        block["omega_sim"] = np.where(sim["oscillating"], sim["omega"], np.nan)
        block["oscillating_sim"] = sim["oscillating"].to_numpy(bool)
        parts.append(block)
    return pd.concat(parts).loc[df.index]

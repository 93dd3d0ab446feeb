"""The ``winding`` chain: the sinusoidal-current approximation of the circuit of Fig 5.10."""

from __future__ import annotations

import numpy as np

from fitdf.chains.base import R_MIN, MeasurementChain, OperatingPoint, as_points
from fitdf.chains.current_solver import solve_current
from fitdf.chains.series_resistance import R_SERIES
from fitdf.models import get_model
from fitdf.params import ParamSpec, split_theta

__all__ = ["WindingChain", "reading"]


def reading(Z, R, gain):
    """The measured DF ``gain Z / (R + Z)`` of a winding of impedance ``Z`` behind ``R`` (sec V.5)."""
    return gain * Z / (R + Z)


class WindingChain(MeasurementChain):
    """Sinusoidal source, series resistance and the core's winding (Fig 5.10, section V.5).

    The winding current amplitude ``I`` solves ``I |R + Z(I, f)| = V`` with
    ``R = R_source + r_series`` and ``Z = j 2 pi f N(I, f)`` (:func:`solve_current`); the
    predicted reading is ``DF = gain Z / (R + Z)``. Where the loop has no height
    (``N = 0``, amplitudes inside a backlash-like dead zone) ``I = V / R`` and ``DF = 0``.
    As ``R -> 0``, ``DF -> gain`` wherever the core can carry the flux ``V / (2 pi f)``,
    i.e. below the saturation voltage ``2 pi f |I N(I)|_max``, which grows linearly with
    ``f`` (Graph 5.3). Above it even a vanishing ``R`` takes the excess voltage.

    ``gain`` is a calibration factor: the 0 ohm tables (B.1, B.2) plateau near 0.95
    rather than 1, and their footnote turns-ratio factors (1250/417, 2000/500) are
    doubtful, so the data demand a free gain; a perfect instrument has ``gain = 1``.
    Only the fundamental is modelled: the distortion of the current (Photos 8, 9) is
    the stated reason why the corrected and measured curves of Graph 5.10 differ.
    """

    name = "winding"
    title = "Winding in series with the source resistance (Fig 5.10)"
    params = (
        R_SERIES,
        ParamSpec(
            "gain",
            1.0,
            (0.5, 1.5),
            unit="1",
            description="calibration gain of the output reading (turns ratio, analyser)",
            equation="Tables B.1-B.5 footnotes",
        ),
    )

    @classmethod
    def _solve(
        cls,
        model,
        amplitude,
        frequency,
        source_impedance,
        model_theta,
        chain_theta,
        initial_current,
    ):
        model = get_model(model)
        V, f, Rs = as_points(amplitude, frequency, source_impedance)
        mkw = split_theta(model.params, model_theta)
        ckw = split_theta(cls.params, chain_theta)
        R = np.maximum(Rs + ckw["r_series"], R_MIN)
        shape = np.broadcast_shapes(V.shape, f.shape, R.shape, *(np.shape(v) for v in mkw.values()))
        # Flat per-point copies let the solver evaluate the model on unconverged points only.
        flat_f = np.broadcast_to(f, shape).ravel()
        flat_kw = {k: np.broadcast_to(v, shape).ravel() for k, v in mkw.items()}

        def impedance(current, index):
            N = model.describing_function(
                current, flat_f[index], **{k: v[index] for k, v in flat_kw.items()}
            )
            return 2j * np.pi * flat_f[index] * N

        current, Z = solve_current(
            impedance, np.broadcast_to(V, shape), np.broadcast_to(R, shape), initial=initial_current
        )

        def inductance(i):
            return model.describing_function(i, f, **mkw)

        return current, Z, reading(Z, R, ckw["gain"]), inductance

    @classmethod
    def predict(
        cls,
        model,
        amplitude,
        frequency,
        source_impedance,
        model_theta,
        chain_theta,
        *,
        initial_current=None,
    ):
        """``gain Z / (R + Z)`` at the self-consistent current; see :meth:`MeasurementChain.predict`."""
        return cls._solve(
            model, amplitude, frequency, source_impedance, model_theta, chain_theta, initial_current
        )[2]

    @classmethod
    def operating_point(
        cls,
        model,
        amplitude,
        frequency,
        source_impedance,
        model_theta,
        chain_theta,
        *,
        initial_current=None,
    ) -> OperatingPoint:
        current, _, df, inductance = cls._solve(
            model, amplitude, frequency, source_impedance, model_theta, chain_theta, initial_current
        )
        N = inductance(current)
        shape = np.broadcast_shapes(df.shape, N.shape)
        return OperatingPoint(*(np.broadcast_to(a, shape).copy() for a in (current, N, df)))

"""The ``direct`` chain: the core's DF read directly, the input only scaled (section V.4.1)."""

from __future__ import annotations

import numpy as np

from fitdf.chains.base import MeasurementChain, OperatingPoint, as_points
from fitdf.models import get_model
from fitdf.params import ParamSpec, split_theta

__all__ = ["DirectChain"]


class DirectChain(MeasurementChain):
    """``DF = N(V / input_scale)``: the core's DF read directly, input scaled to model units.

    The model's gain parameter (``k``, ``mu0``) plays the measured gain, so the model is
    dimensionless here (``k ~ 1``). It ignores ``source_impedance`` and cannot lead:
    ``angle(DF) = angle(N) <= 0`` for every passive loop. This is the comparison of shapes
    that section V.4.1 makes against Graphs 4.2 and 4.4.
    """

    name = "direct"
    winding_units = False  # the law's input is in volts over input_scale
    title = "Core DF read directly (input scale only)"
    params = (
        ParamSpec(
            "input_scale",
            3e3,
            (1.0, 1e7),
            unit="V/A",
            description="input volts per unit of model input (winding current)",
            equation="sec V.4.1 (calibration in input volts)",
            log=True,
        ),
    )

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
        model = get_model(model)
        V, f, _ = as_points(amplitude, frequency, source_impedance)
        scale = split_theta(cls.params, chain_theta)["input_scale"]
        current = V / scale
        N = model.describing_function(current, f, **split_theta(model.params, model_theta))
        current, N = np.broadcast_arrays(current, N)
        return OperatingPoint(current.copy(), N.copy(), N.copy())

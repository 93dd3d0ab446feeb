"""The interface every measurement chain implements, and what they share.

A chain maps a core's complex inductance ``N(I, f)`` (a hysteresis law of
:mod:`fitdf.models`) onto the describing function the thesis measured, voltage out over
voltage in (section V.3). See :mod:`fitdf.chains` for the chains themselves.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from fitdf._text import TEXT_WIDTH, wrap
from fitdf.errors import ModelError
from fitdf.params import Parametrized, ParamSpec

__all__ = ["MeasurementChain", "OperatingPoint", "R_MIN", "as_points"]

#: Smallest series resistance (ohm) the winding solver uses; ``R = 0`` is replaced by it.
R_MIN = 1e-12


@dataclass(frozen=True)
class OperatingPoint:
    """Solved state at each data point (arrays of the broadcast shape): the winding current
    amplitude ``current`` (A, the model's input amplitude), ``inductance`` ``N(I, f)`` (H)
    and the predicted measured ``df``."""

    current: np.ndarray
    inductance: np.ndarray
    df: np.ndarray


def as_points(amplitude, frequency, source_impedance):
    V, f, Rs = (np.asarray(v, dtype=float) for v in (amplitude, frequency, source_impedance))
    if np.any(Rs < 0):
        raise ModelError("source_impedance must be >= 0 ohm")
    return V, f, Rs


class MeasurementChain(Parametrized):
    """Base class: what a chain declares and the three class methods it provides."""

    name: ClassVar[str] = ""
    title: ClassVar[str] = ""
    params: ClassVar[tuple[ParamSpec, ...]] = ()
    #: True when the law's input is the winding current (A) and its output the flux
    #: linkage (V s), so a core's geometry turns its parameters into material constants.
    winding_units: ClassVar[bool] = True

    @classmethod
    def text(cls, width: int = TEXT_WIDTH, brief: bool = False, default: bool = False) -> str:
        """The chain as text within ``width`` columns: name (``default``: marked as the
        default), title, then its parameters (``brief``: their names only)."""
        name = f"{cls.name} (default)" if default else cls.name
        if brief:
            names = ", ".join(p.name for p in cls.params) or "none"
            return "\n".join(wrap(f"{name}: {cls.title}; parameters: {names}", width, "", "    "))
        lines = wrap(f"{name}: {cls.title}", width, "", "    ")
        return "\n".join([*lines, cls.parameters_text("    ", width)])

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
        """Current, inductance and predicted DF at each point (one solve for all three)."""
        raise NotImplementedError

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
        """Complex measured DF.

        Parameters
        ----------
        model : str or HysteresisModel subclass
            The hysteresis law (a registry name or the class).
        amplitude, frequency, source_impedance : array_like
            1-D arrays of the ``n`` data points: input voltage amplitude (V), frequency
            (Hz) and series source resistance (ohm).
        model_theta : array_like
            Model parameters, shape ``(p,)`` or ``(batch, p)``.
        chain_theta : array_like
            Chain parameters, shape ``(q,)`` or ``(batch, q)``.
        initial_current : array_like, optional
            Warm start for chains that solve for the current (e.g. the ``current`` of a
            previous :meth:`operating_point` at nearby parameters); only speed depends on it.

        Returns
        -------
        numpy.ndarray of complex
            Shape ``(n,)`` or ``(batch, n)``; ``angle > 0`` is a phase lead.
        """
        return cls.operating_point(
            model,
            amplitude,
            frequency,
            source_impedance,
            model_theta,
            chain_theta,
            initial_current=initial_current,
        ).df

    @classmethod
    def core_current(
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
        """Amplitude of the winding current (the model's input amplitude), same shape as :meth:`predict`."""
        return cls.operating_point(
            model,
            amplitude,
            frequency,
            source_impedance,
            model_theta,
            chain_theta,
            initial_current=initial_current,
        ).current

"""Measurement chains: from a core's complex inductance ``N(I, f)`` to the measured DF.

The thesis measured its cores as voltage out over voltage in under a sinusoidal source
(section V.3), with the generator straight on the winding (Tables B.1, B.2) and through
600 ohm (section V.5, Tables B.3-B.5). A law of :mod:`fitdf.models` gives ``N``, the flux
linkage per ampere of winding current; a chain maps it onto what the transfer-function
analyser read:

* :class:`~fitdf.chains.voltage.VoltageChain` (``voltage``, the default) -- the circuit of
  Fig 5.10 solved exactly: the periodic steady state of ``V sin(wt) = R i + d lambda/dt``
  with ``R = R_source + r_series``, whatever current waveform the loop makes; the output
  ``gain d lambda/dt`` leads the input where the current lags it (Fig 5.10);
* :class:`~fitdf.chains.winding.WindingChain` (``winding``) -- its sinusoidal-current
  approximation: ``I |R + Z(I, f)| = V`` with ``Z = j 2 pi f N(I, f)``, and
  ``DF = gain Z / (R + Z)``;
* :class:`~fitdf.chains.dynamic.DynamicChain` (``dynamic``) -- the ``voltage`` chain's
  circuit with rate-dependent losses on top of the law's loop: Bertotti's classical
  eddy-current and excess fields, ``i = i_h + c_cl e + c_ex sign(e) |e|^(1/2)``;
* :class:`~fitdf.chains.direct.DirectChain` (``direct``) -- ``DF = N(V / input_scale)``:
  the core as the nonlinearity itself, without source impedance and without phase lead
  (a passive loop has ``Im N <= 0``); the baseline for comparing shapes (section V.4.1).

:func:`get_chain` returns a chain class by name (:data:`CHAINS`). Every chain has ``name``,
``title``, ``params`` and the class methods ``predict``, ``core_current`` and
``operating_point``; ``model_theta`` ``(p,)`` or ``(batch, p)`` and ``chain_theta`` ``(q,)``
or ``(batch, q)`` broadcast, so a batch of parameter vectors evaluates in one call. The
circuit's series resistance and its prior: :mod:`fitdf.chains.series_resistance`.
"""

from __future__ import annotations

from fitdf.chains.base import R_MIN, MeasurementChain, OperatingPoint
from fitdf.chains.current_solver import solve_current
from fitdf.chains.direct import DirectChain
from fitdf.chains.dynamic import DynamicChain
from fitdf.chains.series_resistance import (
    R_SERIES_PRIOR_SIGMA,
    SOURCE_AND_LEADS_OHM,
    series_resistance_prior,
)
from fitdf.chains.voltage import VoltageChain
from fitdf.chains.winding import WindingChain
from fitdf.errors import ModelError

__all__ = [
    "MeasurementChain",
    "DirectChain",
    "WindingChain",
    "VoltageChain",
    "DynamicChain",
    "OperatingPoint",
    "CHAINS",
    "get_chain",
    "chain_names",
    "solve_current",
    "R_MIN",
    "series_resistance_prior",
    "SOURCE_AND_LEADS_OHM",
    "R_SERIES_PRIOR_SIGMA",
]

#: Registered chains by name.
CHAINS: dict[str, type[MeasurementChain]] = {
    c.name: c for c in (DirectChain, WindingChain, VoltageChain, DynamicChain)
}


def chain_names() -> list[str]:
    return list(CHAINS)


def get_chain(name) -> type[MeasurementChain]:
    """Chain class by name (a class passes through); :class:`ModelError` for unknown names."""
    if isinstance(name, type) and issubclass(name, MeasurementChain):
        return name
    if name not in CHAINS:
        raise ModelError(f"unknown measurement chain {name!r}; known chains: {', '.join(CHAINS)}")
    return CHAINS[name]

"""Measurement chains: from a core's complex inductance ``N(I, f)`` to the measured DF.

The thesis measured its cores as *voltage out over voltage in* under a sinusoidal source
(section V.3), once with the generator straight on the winding and once through 600 ohm
(section V.5). A model gives ``N``, the flux linkage per ampere of winding current; a
chain maps ``N`` onto what the transfer-function analyser read:

* :class:`DirectChain` (``direct``) -- ``DF = N(V / input_scale)``: the textbook view in
  which the core *is* the nonlinearity and the input voltage only sets its amplitude
  scale. The model's own gain is the measured gain; there is no source impedance and no
  phase lead (a passive loop has ``Im N <= 0``). The baseline for comparing shapes.
* :class:`WindingChain` (``winding``) -- the circuit of Fig 5.10: source ``V``, series
  resistance ``R = R_source + r_winding``, and the winding of impedance
  ``Z(I, f) = j 2 pi f N(I, f)``. The current amplitude solves ``I |R + Z(I, f)| = V``
  and the output (the core's EMF, read on a secondary winding) over the input is
  ``DF = gain Z / (R + Z)``. Because ``Z`` leads the current by nearly 90 degrees and the
  current lags ``V``, the output *leads* the input (Fig 5.10, Graphs 5.4, 5.12).

Every chain has ``name``, ``title``, ``params`` and the class methods ``predict``,
``core_current`` and ``operating_point``; ``model_theta`` ``(p,)`` or ``(batch, p)`` and
``chain_theta`` ``(q,)`` or ``(batch, q)`` broadcast (MCMC walkers evaluate in one call).
"""

from __future__ import annotations

from fitdf.chains.base import R_MIN, MeasurementChain, OperatingPoint
from fitdf.chains.current_solver import solve_current
from fitdf.chains.direct import DirectChain
from fitdf.chains.voltage import VoltageChain
from fitdf.chains.winding import WindingChain
from fitdf.errors import ModelError

__all__ = [
    "MeasurementChain",
    "DirectChain",
    "WindingChain",
    "VoltageChain",
    "OperatingPoint",
    "CHAINS",
    "get_chain",
    "chain_names",
    "solve_current",
    "R_MIN",
]

#: Registered chains by name.
CHAINS: dict[str, type[MeasurementChain]] = {
    c.name: c for c in (DirectChain, WindingChain, VoltageChain)
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

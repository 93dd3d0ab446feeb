"""Physical data of the thesis's cores (Appendix A) that the fits cannot get from the DF alone.

Why the winding resistance matters
----------------------------------
Every candidate law is closed under a change of current scale: ``N'(I) = s N(s I)`` is the
same law with other parameters (``k -> s k``, ``b -> b / s``, ``c -> c``). In the winding
chain the measured DF is ``Z / (R + Z)`` with ``I |R + Z(I)| = V``; scaling the core by
``s`` *and* the total series resistance ``R`` by ``s`` leaves every measured point
unchanged. So data taken at one source impedance determine the core only up to that
scale, with the winding resistance running along the degenerate direction; a joint fit of
0 and 600 ohm data breaks the symmetry (``r_w`` and ``600 + r_w`` cannot both scale), and
so does knowing ``r_w``. Predicting one source impedance from the other therefore needs
``r_w`` from outside the DF data: :func:`winding_resistance_estimate` gives it from
Appendix A (turns, wire gauge, core dimensions).
"""
from __future__ import annotations

import numpy as np

from fitdf.errors import OptionError

__all__ = ["winding_resistance_estimate", "AWG34_OHM_PER_M", "CASE_ALLOWANCE_IN"]

#: Resistance of #34 AWG copper wire (0.160 mm, 20 degC): rho / area = 1.72e-8 / 2.01e-8 m^2.
AWG34_OHM_PER_M = 0.856
#: Case wall and clearance added on each side of the tape-wound core's cross-section (inch);
#: an assumption (the cases' dimensions are not printed), worth about +-20 % on the estimate.
CASE_ALLOWANCE_IN = 0.06
_INCH = 0.0254


def winding_resistance_estimate(core: str) -> float:
    """DC resistance (ohm) of the driven winding of a thesis core, from Appendix A.

    ``turns x mean turn length x 0.856 ohm/m`` (#34 wire), with the mean turn the perimeter
    of the cased core's cross-section: ``2 ((OD - ID)/2 + h + 4 t)``, ``t`` =
    :data:`CASE_ALLOWANCE_IN`. Gives about 54 ohm (Permalloy, Supermalloy: 1250 turns on a
    2.5 x 2.0 x 0.5 in core) and 43 ohm (Deltamax: 2000 turns on 1.25 x 1.0 x 0.125 in).
    An estimate to perhaps 30 %: the thesis prints no winding resistance.
    """
    from fitdf.data.datasets import load

    table = load("appendix_a")
    rows = table[table["core"] == str(core).lower()]
    if rows.empty:
        raise OptionError(f"no Appendix A data for core {core!r}: give the winding resistance explicitly")

    def value(quantity):
        return float(rows.loc[rows["quantity"] == quantity, "value_min"].astype(float).iloc[0])

    od, idia, h = value("core_outside_diameter"), value("core_inside_diameter"), value("core_height")
    turns = value("primary_turns")
    turn_m = 2.0 * ((od - idia) / 2.0 + h + 4.0 * CASE_ALLOWANCE_IN) * _INCH
    return float(np.round(turns * turn_m * AWG34_OHM_PER_M, 1))

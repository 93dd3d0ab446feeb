r"""The ``dynamic`` chain: the ``voltage`` chain's circuit with Bertotti's rate-dependent losses.

Provides :class:`DynamicChain` (registered as ``dynamic``): the exact periodic steady state
of the circuit of Fig 5.10 (thesis section V.5) when the core's field has, besides the
rate-independent law's, the classical eddy-current and excess (domain-wall) terms of
Bertotti's loss separation in the dynamic-field form.

Notes
-----
*The model.* Bertotti's statistical theory of losses (G. Bertotti, "General properties of power losses
in soft ferromagnetic materials", IEEE Trans. Magn. 24 (1988) 621) separates the loss per
cycle into hysteresis, classical and excess parts; written as fields acting on the
lamination, as in the dynamic models of Zirka et al. (S.E. Zirka, Y.I. Moroz, P. Marketos,
A.J. Moses, "Viscosity-based magnetodynamic model of soft magnetic materials", IEEE Trans.
Magn. 42 (2006) 2121)::

    H = H_stat(B) + k_cl dB/dt + k_ex sign(dB/dt) |dB/dt|^(1/2),
    k_cl = sigma d^2 / 12,        k_ex = (sigma G S V0)^(1/2),

``sigma`` the conductivity, ``d`` the tape thickness, ``S`` the tape's cross-section,
``V0`` the field of the statistical distribution of local coercive fields and
``G = 0.1356`` (Bertotti 1988). ``H_stat`` is the rate-independent law, whatever it is:
with ``H = N i / l_e``, ``lambda = N A_e B`` and the EMF ``e = d lambda/dt`` the winding
current is ``i = i_h + g(e)`` with ``lambda = B(i_h)`` the law's branch and::

    g(e) = c_cl e + c_ex sign(e) |e|^(1/2),
    c_cl = k_cl l_e / (N^2 A_e)      (a conductance, S),
    c_ex = k_ex (l_e / N) (N A_e)^(-1/2)      (A V^-1/2),

(:func:`fitdf.chains._periodic.rate_current`; quantities ``conductance`` and
``current_per_root_voltage`` of :data:`fitdf.params.QUANTITIES`, material limits in
:data:`fitdf.data.cores.MATERIAL_LIMITS`). The circuit is
``V sin(wt) = R i + e = R i_h + R g(e) + e``, the output ``gain e`` (the secondary reads
the flux's rate), the DF its first harmonic over ``V``.

The classical term alone is a linear shunt ``R_p = 1/c_cl`` across the winding:
``V = R i_h + e (1 + R c_cl)`` is the static circuit with the flux scaled by
``k = 1 + R c_cl`` and the output by ``1/k``, so at one source impedance it only trades
against the law's flux scale and the gain; it matters in joint 0 + 600 ohm fits. The
excess term is not such a rescaling: its current grows as the square root of the EMF, so
at small amplitudes it dominates the law's current and gives a loss angle that grows
with frequency.

*The method.* The rate-dependent current vanishes where ``e = 0``, i.e. at the extrema of the flux, so
the turning points are those of the static circuit (``i = i_h``): the branch amplitude is
``i_h``'s peak ``a``, the half period starts at ``phi0 = -arcsin(R a / V)``, and the
``voltage`` chain's root search on ``a`` carries over unchanged. Each implicit step (BDF2,
trapezoidal first step) solves ``R i_h + R g(e) + e = v`` with ``e`` the step's
difference quotient of ``lambda = B(i_h)``; the left side still increases with ``i_h``, so
the cell of the branch table is found as before, and inside a cell the equation is linear
(classical term only: solved exactly) or a quadratic in ``|e|^(1/2)`` (solved exactly,
then one Newton step in the current against rounding where the cell is nearly flat;
:func:`fitdf.chains._periodic._dyn_step`). Two additions to the step control: a step
whose EMF comes out negative (``e < 0`` is ``R i_h > v``) is shortened to locate the flux's
extremum, where ``i_h`` is held at ``max(v/R, i_h)`` with ``e = 0`` (rising on, ``i_h``
would creep past the peak by ``c_ex |e|^(1/2)``, large for the smallest ``|e|``) -- the
static path holds a rising current whose EMF comes out negative in the same way --; and,
on this path only, BDF2's local error, from the quadratic extrapolation of the flux,
refines the steps where the EMF collapses into saturation. One kernel serves both chains:
with both coefficients 0 the static step runs, bit-identical to the ``voltage`` chain.
:meth:`DynamicChain.peak_current` gives the peak of the total current ``i``, which is not
``a`` once ``g != 0`` (it comes before the flux's extremum, while ``e > 0``: up to 18
times ``a`` at small signal with the test's coefficients).

Accuracy (``tests/test_dynamic_chain.py``, ``benchmarks/bench_dynamic.py``): against an
independent time-stepping simulation (``solve_ivp``, rtol 1e-10, the Rayleigh law's
branches switched at the extrema of the flux, the periodic state found by shooting and
checked over whole periods) the DF agrees to 7e-5 at twelve points from small signal
through saturation at 0 and 600 ohm, 3 and 50 Hz, with coefficients that move it by 0.01
to 0.7 (the branch amplitude and peak current to 4e-4). On a grid of 24 points the
largest error is 1.4e-5 at 600 ohm and 1.4e-4 at 0 ohm, just above the knee: there the
branch table limits it (256 nodes instead of 64 take it to 1e-5) and the ``voltage`` chain
is itself off by up to 2e-4 (4e-4 at 1.4 V, 3 Hz). Just above a dead zone's edge
(``constant_width``, ``V/(R b)`` 1-1.2, 3-50 Hz, 0 and 600 ohm, with and without either
coefficient) it agrees to 9.9e-5 at 4920 points with a whole-period reference
(``PlayReference`` in ``tests/test_dynamic_chain.py``; ``benchmarks/dynamic_threshold.py``).
Cost: 1.3 (Preisach) to 2.3 (Rayleigh, a batch of 32) times the ``voltage`` chain's on
Table B.4.

What it does to Supermalloy (``benchmarks/dynamic_supermalloy.py``): Table B.4 with the
Preisach law is fitted no better than through the ``voltage`` chain (RMS complex residual
0.0526 both ways), and the small-signal permeability's fall from 3 to 50 c/s is not
reproduced: the measured fall is carried by the near-lossless 3 c/s, 0.1 V reading, while
an excess or classical loss that gives the 50 c/s row its low Q gives the 3 c/s row
nearly as much.

Bounds
------
The declared boxes (winding units) contain the material limits mapped through all three
thesis cores' geometries (:func:`fitdf.data.cores.core_geometry`). The material limits:
``k_cl`` from 1e-7 S m (negligible: below a 3 um tape's 1.3e-6) to 0.3 S m (a 0.36 mm tape,
the thickest tape-wound cores are made of, at 2.2e6 S/m, times an anomaly factor of 10:
Pry and Bean, J. Appl. Phys. 29 (1958) 532, give ``1.63 (2L/d)`` for domain-wall spacing
``2L``, and wide-domain nickel-iron tapes reach 5-10); ``k_ex`` from 1e-4 (negligible) to
10 A m^-1 (T/s)^-1/2 (``sigma`` 2.2e6 S/m, ``S`` = 0.36 mm x 25 mm, ``V0`` = 10 A/m, above
Bertotti's values for silicon iron, 0.01-1 A/m). Appendix A prints the resistivities
45, 55, 65 micro-ohm cm (Deltamax, Permalloy, Supermalloy): ``sigma`` = 1.5e6-2.2e6 S/m.
"""

from __future__ import annotations

import numpy as np

from fitdf.chains.voltage import VoltageChain, _Points, _solve
from fitdf.params import ParamSpec

__all__ = ["DynamicChain"]


class DynamicChain(VoltageChain):
    """The ``voltage`` chain with the classical and excess eddy-current fields (module docstring).

    Parameters are the ``voltage`` chain's (``r_series``, ``gain``) and ``c_cl`` (S),
    ``c_ex`` (A V^-1/2) of the rate-dependent current ``g(e) = c_cl e + c_ex sign(e)
    |e|^(1/2)``. ``current`` in :meth:`operating_point` is the branch amplitude ``a`` (the
    peak of the law's input ``i_h``, the amplitude the law's ``N(a, f)`` is taken at);
    :meth:`peak_current` gives the peak of the total winding current.
    """

    name = "dynamic"
    title = (
        "Winding behind the source resistance, exact voltage-driven steady state with "
        "Bertotti's classical and excess eddy-current fields (Fig 5.10)"
    )
    params = VoltageChain.params + (
        ParamSpec(
            "c_cl",
            2e-7,
            (1e-10, 1e-3),
            unit="S",
            description=(
                "classical eddy-current conductance across the winding, "
                "k_cl l_e / (N^2 A_e) with k_cl = sigma d^2 / 12"
            ),
            equation="Bertotti 1988; Zirka et al. 2006",
            log=True,
            quantity="conductance",
        ),
        ParamSpec(
            "c_ex",
            5e-5,
            (1e-8, 1e-2),
            unit="A V^-1/2",
            description=(
                "excess-loss coefficient, current c_ex sign(e) |e|^(1/2) of the EMF e; "
                "k_ex (l_e / N) (N A_e)^(-1/2) with k_ex = (sigma G S V0)^(1/2)"
            ),
            equation="Bertotti 1988; Zirka et al. 2006",
            log=True,
            quantity="current_per_root_voltage",
        ),
    )

    @classmethod
    def _rate(cls, ckw, shape):
        return tuple(np.broadcast_to(ckw[k], shape).ravel().copy() for k in ("c_cl", "c_ex"))

    @classmethod
    def peak_current(
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
        """Peak of the total winding current ``i = i_h + g(e)`` over the period (A).

        The steady state's rising half is integrated once more at the solved branch
        amplitude ``a``, on the fine nodes of the search; the peak is ``a`` plus the excess of
        that run's largest total current over its largest ``i_h`` (the root is within the
        search's tolerance, and the excess hardly moves with ``a``): exactly ``a`` with both
        coefficients 0. Same shape as :meth:`predict`.
        """
        st = cls.settings
        model, shape, V, f, R, flat, _, ckw = cls._prepare(
            model, amplitude, frequency, source_impedance, model_theta, chain_theta
        )
        initial = None
        if initial_current is not None:
            initial = np.broadcast_to(np.asarray(initial_current, float), shape).ravel()
        rate = cls._rate(ckw, shape)
        current, _, u, _ = _solve(model, V, f, R, flat, initial, st, rate)
        peak = np.zeros(V.size)
        live = np.flatnonzero(V > 0)
        if live.size:
            pts = _Points(model, V, f, R, flat, st.threads, rate)
            a = current[live]
            excess = pts.run(live, a, u[live], st.steps, st.refine_factor, peak=True)[3]
            peak[live] = a + excess
        return peak.reshape(shape)

"""The loop's nonlinear element as harmonic balance takes it: ``N(A, omega)``.

A fitted result gives the measured describing function of its core at a source
impedance; a callable is used as it is. :func:`_evaluate_N` evaluates either on a grid.
"""

from __future__ import annotations

import numpy as np

from fitdf.errors import OptionError

__all__ = ["as_describing_function"]


def as_describing_function(nonlinearity, source_impedance: float = 0.0):
    """``(N(A, omega), default amplitude range, label)`` for a fitted result or a callable.

    A fitted result (anything with ``predict(amplitude, frequency_hz, source_impedance)``)
    gives the *measured* DF of the core at ``source_impedance`` -- the element the
    thesis put in the loop; its default amplitude range is that of the rows it was
    fitted to. A callable must take ``(A, omega)`` (rad/s) and broadcast.
    """
    if hasattr(nonlinearity, "predict"):
        fitted = nonlinearity
        rs = float(source_impedance)

        def N(A, omega):
            return fitted.predict(A, np.asarray(omega, float) / (2.0 * np.pi), rs)

        rng = None
        data = getattr(getattr(fitted, "problem", None), "data", None)
        if data is not None:
            amp = np.asarray(data.amplitude, float)
            amp = amp[amp > 0]
            if amp.size:
                rng = (float(amp.min()), float(amp.max()))
        label = f"{getattr(fitted, 'model', 'fit')} ({getattr(fitted, 'chain', '')}) at {rs:g} ohm"
        return N, rng, label
    if callable(nonlinearity):
        return nonlinearity, None, getattr(nonlinearity, "__name__", "N")
    raise OptionError(
        f"cannot use a {type(nonlinearity).__name__} as a nonlinearity; give a fitted "
        "result or a callable N(A, omega)"
    )


def _evaluate_N(N, A, omega):
    """``N`` on the broadcast of ``A`` and ``omega``, NaN where it is not finite."""
    A, omega = np.broadcast_arrays(np.asarray(A, float), np.asarray(omega, float))
    with np.errstate(all="ignore"):
        out = np.broadcast_to(np.asarray(N(A, omega), complex), A.shape).copy()
    out[~np.isfinite(out)] = np.nan
    return out

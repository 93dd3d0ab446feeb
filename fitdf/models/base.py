"""The interface every hysteresis law implements.

A model is a class with declarative :class:`~fitdf.params.ParamSpec` s and two pure,
vectorised class methods:

* :meth:`HysteresisModel.ascending_branch` -- the steady-state loop itself (used by the
  numerical referee in :mod:`fitdf.numerical_df` and by time-domain simulation);
* :meth:`HysteresisModel.describing_function` -- the closed form ``N(A, f)``; laws
  without one fall back to the numerical engine.

Models know nothing of data, chains or fitting. Units follow the winding chain: input
``x`` is the winding current (A) and output the flux linkage (V s), so ``N`` is an
amplitude-dependent complex inductance (H). Any other consistent units work too.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from fitdf._text import TEXT_WIDTH, wrap
from fitdf.numerical_df import numerical_describing_function
from fitdf.params import Parametrized, ParamSpec, split_theta

__all__ = ["HysteresisModel"]


class HysteresisModel(Parametrized):
    """Base class of the describing-function models (one subclass per law)."""

    #: Thesis equations the law and its describing function come from.
    equations: ClassVar[str] = ""
    #: Parameters in the order of the ``theta`` vector.
    params: ClassVar[tuple[ParamSpec, ...]] = ()
    #: True when ``N`` depends on frequency as well as amplitude.
    frequency_dependent: ClassVar[bool] = False
    #: True when :meth:`describing_function` is a closed form (else numerical).
    closed_form: ClassVar[bool] = True
    #: How many times the usual number of least-squares starts the law's chi-square needs.
    #: More than 1 for a law whose loop family clips (a kink in chi-square): its polishes
    #: stop on many ledges, and the usual few starts can all miss the best basin.
    start_multiple: ClassVar[int] = 1

    @classmethod
    def ascending_branch(cls, x, amplitude, frequency=0.0, **theta):
        """Output on the rising branch of the loop with peak input ``amplitude``."""
        raise NotImplementedError

    @classmethod
    def rough_branch(cls, x, amplitude, frequency=0.0, **theta):
        """:meth:`ascending_branch` to the accuracy a first, coarse search needs (~1e-4 of
        the tip), where a law computes its loop numerically and a rough loop is cheaper (a
        root search's coarse stage and initial guess; its fine stage uses the exact branch).
        The exact branch by default."""
        return cls.ascending_branch(x, amplitude, frequency, **theta)

    @classmethod
    def describing_function(cls, amplitude, frequency=0.0, **theta):
        """Complex describing function ``N(A, f)``; broadcasts over all arguments."""
        return cls.numerical_describing_function(amplitude, frequency, **theta)

    @classmethod
    def numerical_describing_function(cls, amplitude, frequency=0.0, *, n_points=None, **theta):
        """``N`` from the numerical Fourier integral of :meth:`ascending_branch`."""
        kw = {} if n_points is None else {"n_points": n_points}
        return numerical_describing_function(
            cls.ascending_branch, amplitude, frequency, **kw, **theta
        )

    @classmethod
    def limit_warnings(cls, amplitude, **theta) -> list[str]:
        """Where the law at ``theta`` meets, at the peak inputs ``amplitude``, a limit of its
        loop family that no parameter bound shows (a clip inside the law): one sentence
        each, for the fit's warnings. None by default."""
        return []

    @classmethod
    def evaluate(cls, amplitude, frequency, theta):
        """Batched ``N``: ``theta`` of shape ``(..., p)`` gives a result of shape ``(..., n)``.

        ``amplitude`` and ``frequency`` are 1-D arrays of the ``n`` points.
        """
        return cls.describing_function(
            np.asarray(amplitude, float),
            np.asarray(frequency, float),
            **split_theta(cls.params, theta),
        )

    @classmethod
    def text(cls, width: int = TEXT_WIDTH, brief: bool = False) -> str:
        """The law as text within ``width`` columns: name, title and thesis equations, whether
        ``N`` depends on frequency, then its parameters (``brief``: without their meanings)."""
        if brief:
            rate = "; N depends on frequency" if cls.frequency_dependent else ""
            lines = wrap(f"{cls.name}: {cls.title} ({cls.equations}){rate}", width, "", "    ")
            return "\n".join([*lines, cls.parameters_text("    ", width, meanings=False)])
        lines = wrap(f"{cls.name}: {cls.title}", width, "", "  ")
        lines += wrap(f"thesis equations: {cls.equations}", width, "  ", "    ")
        lines.append(
            "  N depends on the frequency as well as the amplitude"
            if cls.frequency_dependent
            else "  N depends on the amplitude only (rate-independent loop)"
        )
        lines += ["", "Parameters of the law (the core's flux linkage against winding current):"]
        return "\n".join([*lines, cls.parameters_text("  ", width)])

    @classmethod
    def _extra_description(cls) -> dict:
        return {
            "equations": cls.equations,
            "frequency_dependent": cls.frequency_dependent,
            "closed_form": cls.closed_form,
            "start_multiple": cls.start_multiple,
        }

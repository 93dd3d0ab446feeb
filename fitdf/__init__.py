"""fitdf: fit, compare and use describing-function models of hysteretic elements.

Built from the thesis *On the derivation of the describing function for hysteretic
nonlinear elements*: the candidate hysteresis laws (Chapters II-IV), the measured
describing functions of three magnetic cores (Chapter V, Appendix B), and limit-cycle
prediction in a closed loop (section V.6).

The public API is imported lazily so that ``fitdf --version`` stays fast.
"""

from importlib import import_module
from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as _version

try:
    __version__ = _version("fitdf")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.1.0"

from fitdf.errors import DataError, FitdfError, ModelError, OptionError

_LAZY = {
    "fit": ("fitdf.inference.api", "fit"),
    "compare": ("fitdf.inference.ranking", "compare"),
    "cross_impedance": ("fitdf.inference.cross_impedance", "cross_impedance"),
    "limit_cycles": ("fitdf.loop.harmonic", "limit_cycles"),
    "get_model": ("fitdf.models", "get_model"),
    "model_names": ("fitdf.models", "model_names"),
    "get_chain": ("fitdf.chains", "get_chain"),
    "FitResult": ("fitdf.inference.results", "FitResult"),
    "PosteriorResult": ("fitdf.inference.results", "PosteriorResult"),
    "NoiseModel": ("fitdf.data.fitdata", "NoiseModel"),
    "datasets": ("fitdf.datasets", None),
    "audit": ("fitdf.audit", None),
    "models": ("fitdf.models", None),
    "plots": ("fitdf.plots", None),
    "report": ("fitdf.report", None),
}

__all__ = ["__version__", "FitdfError", "DataError", "ModelError", "OptionError", *_LAZY]


def __getattr__(name):
    if name not in _LAZY:
        raise AttributeError(f"module 'fitdf' has no attribute {name!r}")
    module, attr = _LAZY[name]
    mod = import_module(module)
    value = mod if attr is None else getattr(mod, attr)
    globals()[name] = value
    return value


def __dir__():
    return sorted(__all__)

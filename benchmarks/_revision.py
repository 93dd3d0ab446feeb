"""The chains' root search as it was at another git revision, to run beside this checkout's.

:func:`secant_update_at` loads ``fitdf/chains/_periodic.py`` as it was at a revision as a
module of its own (compiled into a temporary folder, removed at exit) and returns its
``secant_update``, the per-point step of the root search of the ``voltage`` and ``dynamic``
chains; :func:`root_search` makes the chains use it. Only that step is swapped: its signature
must be this checkout's.
"""

from __future__ import annotations

import atexit
import contextlib
import importlib
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import fitdf.chains.voltage as _voltage

ROOT = Path(__file__).resolve().parents[1]


def secant_update_at(rev):
    """The compiled ``secant_update`` of ``fitdf/chains/_periodic.py`` at the revision ``rev``."""
    text = subprocess.run(
        ["git", "-C", str(ROOT), "show", f"{rev}:fitdf/chains/_periodic.py"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    folder = Path(tempfile.mkdtemp(prefix="fitdf-revision-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    name = "_periodic_" + re.sub(r"\W", "_", rev)
    (folder / f"{name}.py").write_text(text)
    sys.path.insert(0, str(folder))
    return importlib.import_module(name).secant_update


@contextlib.contextmanager
def root_search(step):
    """Within the block, the chains' root search steps with ``step``."""
    saved = _voltage.secant_update
    _voltage.secant_update = step
    try:
        yield
    finally:
        _voltage.secant_update = saved

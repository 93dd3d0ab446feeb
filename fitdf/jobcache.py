"""Finished jobs kept on disk, so that a stopped or repeated run does not compute them again.

A job of the :class:`~fitdf.executor.Executor` is ``(fn, args)`` under a key, and depends
only on its arguments (the executor's contract: where it runs changes no number). Its result
is kept under the SHA-256 of its function's name, its key and a *salt*: the salt must name
everything the run's arguments are made from, so that within one salt a key names one job
with one set of arguments. For a report that is its settings and seed, fitdf's code, the
bundled data and the machine (the same seed gives the same numbers only on the same CPU with
the same libraries, :mod:`fitdf.machine`): :func:`fitdf.report.build.job_cache`; for
``fitdf fit``, the rows' contents and the fit's options instead of the report's settings:
:func:`fitdf.inference.cache.comparison_cache` (both through :func:`run_salt`). A kept
result is therefore the one the job would compute again, to the bit. (The arguments
themselves are not hashed: a pickle is not canonical, the same fit pickles to other bytes
once it has been through a pickle, as pandas and string interning rearrange it.)
Entries of one salt live in their own folder, so a change of code, data or machine starts
an empty one.

Writes are atomic (a temporary file renamed into place): a run killed while writing leaves
no half entry, and two runs sharing a folder each see whole entries or none. The cache is an
optimisation: an entry that cannot be written or read is skipped (a miss), never an error.
Entries are pickles, which can run code when loaded: keep the folder private (the default,
under the user's cache folder, is).

Layout: ``<folder>/<salt[:20]>/<digest[:2]>/<digest>.pkl``. Salt folders not written to for
:data:`STALE_DAYS` days (another code version's) are removed when a cache is opened.
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import shutil
import tempfile
import time
from pathlib import Path

from fitdf.machine import machine_record, versions

__all__ = ["JobCache", "default_cache_folder", "files_digest", "run_salt"]

#: Salt folders untouched for this many days are removed by :meth:`JobCache.__init__`.
STALE_DAYS = 7
#: Pickle protocol of the entries.
PROTOCOL = 5


def default_cache_folder() -> Path:
    """``$XDG_CACHE_HOME/fitdf/jobs``, else ``~/.cache/fitdf/jobs``."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "fitdf" / "jobs"


def files_digest(*folders, suffixes=(".py", ".csv", ".json")) -> str:
    """SHA-256 of the files with these suffixes under ``folders``: their paths relative to
    their folder, and their bytes, in sorted order (compiled caches and the like are left out)."""
    h = hashlib.sha256()
    for folder in folders:
        folder = Path(folder)
        files = sorted(p for p in folder.rglob("*") if p.suffix in suffixes and p.is_file())
        for p in files:
            h.update(p.relative_to(folder).as_posix().encode())
            h.update(b"\0")
            h.update(p.read_bytes())
            h.update(b"\0")
    return h.hexdigest()


def run_salt(parts: dict, folders, libraries=()) -> str:
    """The salt of a run's cache: ``parts`` (what its jobs' arguments are made from: settings,
    seed, the rows fitted) with what every number depends on besides: the machine record
    (:mod:`fitdf.machine`), the versions of ``libraries``, fitdf's version and a digest of
    ``folders`` (fitdf's source, the bundled data). A canonical JSON text."""
    return json.dumps(
        {
            **parts,
            "machine": machine_record(),
            "libraries": versions(libraries),
            "fitdf": versions(("fitdf",))["fitdf"],  # (None in an uninstalled tree)
            "files": files_digest(*folders),
        },
        sort_keys=True,
    )


class JobCache:
    """Results of finished jobs under a digest of ``(fn, args)`` and ``salt``.

    Parameters
    ----------
    folder : str or Path
        Root of the cache (created on the first write).
    salt : str
        Everything the jobs' arguments are made from (see the module docstring).

    Attributes
    ----------
    hits, written : int
        Jobs served from the cache and results written to it, by this object.
    """

    def __init__(self, folder, salt: str):
        self.root = Path(folder)
        self.salt = str(salt)
        self.folder = self.root / hashlib.sha256(self.salt.encode()).hexdigest()[:20]
        self.hits = 0
        self.written = 0
        self._remove_stale()

    def __repr__(self):
        return f"JobCache({str(self.root)!r}, hits={self.hits}, written={self.written})"

    def _remove_stale(self) -> None:
        """Other salts' folders untouched for :data:`STALE_DAYS` days (disk is not unbounded)."""
        if not self.root.is_dir():
            return
        cutoff = time.time() - STALE_DAYS * 86400.0
        for entry in self.root.iterdir():
            try:
                if entry != self.folder and entry.is_dir() and entry.stat().st_mtime < cutoff:
                    shutil.rmtree(entry, ignore_errors=True)
            except OSError:
                continue

    def digest(self, fn, key) -> str | None:
        """SHA-256 of the salt, ``fn``'s module and name and the ``repr`` of ``key`` (a tuple
        of strings and numbers: exact and canonical); None for a function without a name to
        import it by (a lambda or a local function: such a job is not kept)."""
        name = f"{getattr(fn, '__module__', None)}.{getattr(fn, '__qualname__', '<>')}"
        if "<" in name or name.startswith("None."):
            return None
        h = hashlib.sha256(self.salt.encode())
        for part in (name, repr(tuple(key))):
            h.update(b"\0")
            h.update(part.encode())
        return h.hexdigest()

    def _path(self, digest: str) -> Path:
        return self.folder / digest[:2] / f"{digest}.pkl"

    def get(self, digest: str | None):
        """``(True, value)`` for a kept entry, else ``(False, None)`` (a damaged entry is removed)."""
        if digest is None:
            return False, None
        path = self._path(digest)
        try:
            with open(path, "rb") as f:
                value = pickle.load(f)
        except FileNotFoundError:
            return False, None
        except Exception:  # damaged, or from an incompatible version of a class: a miss
            path.unlink(missing_ok=True)
            return False, None
        self.hits += 1
        return True, value

    def put(self, digest: str | None, value) -> bool:
        """Keep ``value`` under ``digest`` (atomically); False where it could not be written."""
        if digest is None:
            return False
        path = self._path(digest)
        tmp = None
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=".tmp-", dir=path.parent)
            with os.fdopen(fd, "wb") as f:
                pickle.dump(value, f, protocol=PROTOCOL)
            os.replace(tmp, path)
        except Exception:  # a full disk, a read-only folder, a value that does not pickle
            if tmp is not None:
                Path(tmp).unlink(missing_ok=True)
            return False
        self.written += 1
        return True

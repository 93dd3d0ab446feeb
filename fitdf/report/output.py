"""The report's folder: its files written, swapped in atomically, and never replaced by surprise.

Files
    :func:`write_outputs` writes ``results.json`` (every number), ``README.md`` and
    ``index.html`` (:mod:`fitdf.report.render`) and ``costs.json`` (what each job took,
    :func:`fitdf.report.costs.cost_record`) into a folder the figures are already in.
Atomic output
    A run builds its report in a temporary sibling of the report folder
    (:func:`temporary_folder`) which then replaces it (:func:`swap_in`: two renames, the
    old report restored if the second fails): an interrupted or failed run leaves the
    previous report as it was. The temporary folder is named ``.<out>.tmp-<pid>-*``; one
    whose process is gone (a run killed outright) is removed by the next run
    (:func:`remove_stale`).
A lesser report never replaces a more complete one
    Before anything is computed, :func:`check_replace` reads the report already in the
    folder: a run that would lose something it holds (posteriors, cross-validation, laws,
    blocks, ...: :func:`fitdf.report.settings.lost_by`) is refused with one line naming
    that report's run and the way out, unless asked to replace it.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
from pathlib import Path

from fitdf.errors import OptionError
from fitdf.report import render
from fitdf.report.costs import cost_record
from fitdf.report.settings import lost_by
from fitdf.report.upgrade import upgrade

__all__ = [
    "write_outputs",
    "temporary_folder",
    "remove_stale",
    "swap_in",
    "existing_report",
    "check_replace",
    "LesserReport",
]


def write_outputs(results: dict, out_dir: Path) -> None:
    """results.json, README.md, index.html and costs.json into ``out_dir`` (figures already
    there)."""
    out_dir = Path(out_dir)

    def write(name: str, text: str) -> None:
        # each file whole or not at all (a report folder is also written in place:
        # fitdf.report.small_signal_study)
        tmp = out_dir / f".{name}.tmp"
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, out_dir / name)

    write("results.json", json.dumps(results, indent=1, allow_nan=False, ensure_ascii=False) + "\n")
    write("README.md", render.render_markdown(results))
    write("index.html", render.render_html(results, out_dir))
    write("costs.json", json.dumps(cost_record(results), indent=1, allow_nan=False) + "\n")


def _tmp_pattern(out_dir: Path) -> re.Pattern:
    """Names of the temporary folders of ``out_dir``: ``.<name>.tmp-<pid>-<random>``."""
    return re.compile(rf"\.{re.escape(out_dir.name)}\.tmp-(\d+)-")


def temporary_folder(out_dir: Path) -> Path:
    """A new temporary sibling of ``out_dir`` for this process's run (readable by all)."""
    tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.tmp-{os.getpid()}-", dir=out_dir.parent))
    os.chmod(tmp, 0o755)  # mkdtemp makes it private; the report is meant to be read
    return tmp


def _running(pid: int) -> bool:
    """Whether process ``pid`` exists (anything but POSIX: assume it does)."""
    if os.name != "posix" or pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process
        return True
    return True


def remove_stale(out_dir: Path) -> list[Path]:
    """Remove the temporary folders of ``out_dir`` whose run is gone (killed outright)."""
    pattern, removed = _tmp_pattern(out_dir), []
    for path in out_dir.parent.iterdir():
        match = pattern.match(path.name)
        if match and path.is_dir() and not _running(int(match.group(1))):
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path)
    return removed


def swap_in(tmp: Path, out_dir: Path) -> None:
    """Replace ``out_dir`` by ``tmp``; on failure the old ``out_dir`` is restored."""
    if not out_dir.exists():
        os.replace(tmp, out_dir)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.old-", dir=out_dir.parent))
    old.rmdir()
    os.replace(out_dir, old)
    try:
        os.replace(tmp, out_dir)
    except BaseException:
        os.replace(old, out_dir)
        raise
    shutil.rmtree(old, ignore_errors=True)


class LesserReport(OptionError):
    """The run would replace a more complete report (:func:`check_replace`)."""


def existing_report(out_dir) -> dict | None:
    """The ``results.json`` record of the report in ``out_dir`` (current schema), or None when
    there is none that says what it computed (no file, unreadable, no ``settings``)."""
    path = Path(out_dir) / "results.json"
    try:
        record = upgrade(json.loads(path.read_text(encoding="utf-8")))
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) and isinstance(record.get("settings"), dict) else None


def _made_by(record: dict) -> str:
    """The run that made a report: its command, or "settings of its own"."""
    command = (record.get("run") or {}).get("command")
    return f"`{command}`" if command else "settings of its own"


def check_replace(out_dir, settings: dict, command: str | None) -> None:
    """Refuse to replace the report in ``out_dir`` by a run of ``settings`` (their
    ``results.json`` record) that would lose something it holds: what its settings computed
    and these do not (:func:`~fitdf.report.settings.lost_by`), or a small-signal study added
    to it (:mod:`fitdf.report.small_signal_study`), which no run of ``fitdf report`` makes.

    Raises
    ------
    LesserReport
        One line: the report there, what this run (``command``, None: settings of its own)
        would lose, and the ways out (another folder, or ``--replace``).
    """
    old = existing_report(out_dir)
    if old is None:
        return
    lost = lost_by(old["settings"], settings)
    if old.get("small_signal_evidence"):  # added after its run: no run of fitdf report makes it
        lost.append("small-signal study (python -m fitdf.report.small_signal_study)")
    if not lost:
        return
    this = f"`{command}`" if command else "these settings"
    raise LesserReport(
        f"{out_dir} holds a report made by {_made_by(old)}; {this} would replace it without "
        f"its {', '.join(lost)}: write elsewhere (--out DIR) or replace it (--replace)"
    )

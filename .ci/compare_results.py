#!/usr/bin/env python3
"""Compare two results.json files of `fitdf report`, timing fields aside.

Usage: python .ci/compare_results.py OLD/results.json NEW/results.json [--rtol 0] [--as-is]
Prints every path whose value differs (numbers beyond --rtol) and exits 1 when any does.
Used to show that a refactoring changes no number.

Both files are first read as the current schema (fitdf/report/upgrade.py of this checkout:
a file written before a rename, such as `fits_mcmc` -> `fits_posterior`, compares with one
written after it under the new names); --as-is compares them as written.
"""

import argparse
import importlib.util
import json
import math
import sys
from pathlib import Path

#: The checkout's schema upgrade, loaded from its file alone (no numerical stack imported,
#: and this checkout's, whichever fitdf is installed).
_UPGRADE = Path(__file__).resolve().parents[1] / "fitdf" / "report" / "upgrade.py"


def upgrade_function():
    spec = importlib.util.spec_from_file_location("_fitdf_report_upgrade", _UPGRADE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.upgrade


SKIP = {"timing", "fitdf_version"}


def walk(a, b, path, out, rtol):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k in SKIP:
                continue
            if k not in a or k not in b:
                out.append(f"{path}/{k}: only in {'new' if k not in a else 'old'}")
                continue
            walk(a[k], b[k], f"{path}/{k}", out, rtol)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{path}: length {len(a)} != {len(b)}")
        for i, (x, y) in enumerate(zip(a, b)):
            walk(x, y, f"{path}[{i}]", out, rtol)
    elif isinstance(a, float) and isinstance(b, float):
        if not (a == b or (rtol and math.isclose(a, b, rel_tol=rtol))):
            out.append(f"{path}: {a!r} != {b!r}")
    elif a != b:
        out.append(f"{path}: {a!r} != {b!r}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--rtol", type=float, default=0.0)
    ap.add_argument(
        "--as-is", action="store_true", help="compare the files as written (no schema upgrade)"
    )
    args = ap.parse_args()
    with open(args.old) as f:
        old = json.load(f)
    with open(args.new) as f:
        new = json.load(f)
    if not args.as_is:
        upgrade = upgrade_function()
        old, new = upgrade(old), upgrade(new)
    diffs = []
    walk(old, new, "", diffs, args.rtol)
    for d in diffs[:200]:
        print(d)
    print(f"{len(diffs)} differences" + (" (first 200 shown)" if len(diffs) > 200 else ""))
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main())

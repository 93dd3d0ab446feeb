#!/usr/bin/env python3
"""Compare two results.json files of `fitdf report`, timing fields aside.

Usage: python .ci/compare_results.py OLD/results.json NEW/results.json [--rtol 0]
Prints every path whose value differs (numbers beyond --rtol) and exits 1 when any does.
Used to show that a refactoring changes no number.
"""

import argparse
import json
import math
import sys

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
    args = ap.parse_args()
    with open(args.old) as f:
        old = json.load(f)
    with open(args.new) as f:
        new = json.load(f)
    diffs = []
    walk(old, new, "", diffs, args.rtol)
    for d in diffs[:200]:
        print(d)
    print(f"{len(diffs)} differences" + (" (first 200 shown)" if len(diffs) > 200 else ""))
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main())

"""Refresh the package's copy of the committed report's job costs:
``python -m fitdf.report.refresh_costs reports`` writes ``fitdf/report/committed_costs.json``
(:data:`fitdf.report.costs.COMMITTED`) from the committed report's ``results.json``
(:func:`fitdf.report.costs.cost_record`), after the report is regenerated. A field the
report's record lacks (written before it existed: the cores, the command) keeps the package
copy's value.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from fitdf.report.costs import COMMITTED_FILE, COMMITTED_RUN, cost_record
from fitdf.report.upgrade import read_results

__all__ = ["main"]


def main(argv=None) -> int:
    """``python -m fitdf.report.refresh_costs REPORT``: refresh the package's copy of the committed
    costs (``committed_costs.json``) from the report in the folder ``REPORT`` (its
    ``results.json``)."""
    parser = argparse.ArgumentParser(
        prog="python -m fitdf.report.refresh_costs", description=main.__doc__
    )
    parser.add_argument("report", type=Path, help="the committed report's folder (reports)")
    parser.add_argument(
        "--out", type=Path, default=COMMITTED_FILE, help="where to write (default: the package's)"
    )
    args = parser.parse_args(argv)
    record = cost_record(read_results(args.report), known=COMMITTED_RUN)
    args.out.write_text(json.dumps(record, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    run = record["run"]
    print(
        f"{args.out}: {len(record['jobs_s'])} jobs of `{run['command']}`, "
        f"{run['total_s']} s on {run['workers']} workers ({run['cpu']})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""``python -m fitdf``: the command line (:mod:`fitdf.cli`)."""

import sys

from fitdf.cli import main

if __name__ == "__main__":
    sys.exit(main())

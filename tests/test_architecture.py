"""The package's architecture, enforced: layers, no hidden imports, a public API that always works.

The layer order lives in pyproject.toml (``[tool.importlinter]``): cli > cli_parser > report >
plots > limit_cycle_tables > loop > inference > chains > models > numerical_df | data > params |
_json | _arviz | executor > errors | jobcache > machine | _text | stop_signals.
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import fitdf

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "fitdf"


def test_every_import_points_down():
    """import-linter's layers contract over the whole import graph (function bodies included)."""
    exe = shutil.which("lint-imports") or str(Path(sys.executable).with_name("lint-imports"))
    run = subprocess.run([exe, "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    assert "1 kept, 0 broken" in run.stdout


#: The function-level imports allowed, by file: a dependency slow to import, imported only by
#: the run that uses it (Dask: only a report on a cluster needs it; ArviZ, 1-3 s, and corner,
#: which imports it: only MCMC, LOO comparisons and corner plots, not a least-squares fit or
#: a limit cycle, tests/test_cli_fast.py; nautilus, about 1 s with scikit-learn: only nested
#: sampling).
ALLOWED_HIDDEN = {
    "fitdf/inference/nested.py": {"import nautilus"},
    "fitdf/executor.py": {"import distributed"},
    "fitdf/_arviz.py": {"import arviz"},
    "fitdf/plots/posterior.py": {"import corner"},
}

#: And the command line's subcommand handlers (module-level ``cmd_*`` functions of
#: fitdf/cli.py): each imports what its subcommand needs as the first statements of its
#: body, so that ``fitdf --version`` and ``--help`` load no numerical stack
#: (tests/test_cli_fast.py). Nowhere else, not in functions nested in a handler, and
#: import-linter still checks these imports against the layers.
LAZY_HANDLERS = ("fitdf/cli.py", "cmd_")


def _handler_imports(path: Path, tree: ast.Module) -> set:
    """The import statements heading the CLI's subcommand handlers (ids of the nodes)."""
    where, prefix = LAZY_HANDLERS
    if path.relative_to(ROOT).as_posix() != where:
        return set()
    allowed = set()
    for func in tree.body:
        if isinstance(func, ast.FunctionDef) and func.name.startswith(prefix):
            body = func.body[1:] if ast.get_docstring(func) is not None else func.body
            for stmt in body:
                if not isinstance(stmt, (ast.Import, ast.ImportFrom)):
                    break
                allowed.add(id(stmt))
    return allowed


def test_no_imports_hidden_inside_functions():
    """Imports sit at the top of the module, where a reader (and the import graph) sees them."""
    hidden = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        allowed = ALLOWED_HIDDEN.get(path.relative_to(ROOT).as_posix(), set())
        handlers = _handler_imports(path, tree)
        for func in ast.walk(tree):
            if isinstance(func, (ast.FunctionDef, ast.AsyncFunctionDef)):
                hidden += [
                    f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}"
                    for node in ast.walk(func)
                    if isinstance(node, (ast.Import, ast.ImportFrom))
                    and ast.unparse(node) not in allowed
                    and id(node) not in handlers
                ]
    assert not hidden, "\n".join(hidden)


def test_no_self_inspection():
    """The package never probes itself (signatures, optional own modules) at run time."""
    offenders = []
    for path in sorted(PACKAGE.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        for needle in (
            "inspect.signature",
            "import inspect",
            "except ImportError",
            "ModuleNotFoundError",
        ):
            if needle in text and not (
                path.name == "datasets.py" and needle == "ModuleNotFoundError"
            ):
                offenders.append(f"{path.relative_to(ROOT)}: {needle}")
    assert not offenders, offenders


def test_public_api_works_whatever_was_imported_first():
    """Importing every submodule first must not shadow the public names (``fitdf.compare`` was a module)."""
    for info in pkgutil.walk_packages(fitdf.__path__, "fitdf."):
        importlib.import_module(info.name)
    for name in ("fit", "compare", "cross_impedance", "limit_cycles", "get_model", "get_chain"):
        assert callable(getattr(fitdf, name)), name
    assert callable(fitdf.datasets.load) and callable(fitdf.audit.audit)
    table = fitdf.compare("B.1", models=["constant_width"], cross_validation=False, n_starts=1)
    assert list(table["model"]) == ["constant_width"] and table["rms_complex"].iloc[0] < 0.2


@pytest.mark.parametrize("name", fitdf.__all__)
def test_every_public_name_resolves(name):
    assert getattr(fitdf, name) is not None


def test_public_modules_import_by_their_dotted_names():
    """``import fitdf.datasets`` (as the README writes it) and ``import fitdf.audit`` work in a
    fresh interpreter, and are the modules ``fitdf.datasets`` and ``fitdf.audit`` give."""
    code = (
        "import fitdf.datasets, fitdf.audit, fitdf, sys; "
        "assert fitdf.datasets is sys.modules['fitdf.datasets']; "
        "assert fitdf.audit.audit is sys.modules['fitdf.data.audit'].audit; "
        "print(len(fitdf.datasets.load('B.1')))"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    assert int(run.stdout) == len(fitdf.datasets.load("B.1")) > 0

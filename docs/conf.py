"""Sphinx configuration of the fitdf documentation.

Build (from the repository root, after ``pip install ".[docs]"``)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html
"""

import sys
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent / "_ext"))

project = "fitdf"
author = "the fitdf authors"
copyright = "fitdf authors, MIT licence"
try:
    release = version("fitdf")
except PackageNotFoundError:  # building from a checkout that is not installed
    release = "0.1.0"
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "fitdf_cli",  # docs/_ext/fitdf_cli.py: the CLI reference, rendered from the parser
    "fitdf_values",  # docs/_ext/fitdf_values.py: :value: writes a constant of the code
]

templates_path = ["_templates"]

exclude_patterns = ["_build"]
root_doc = "index"

# -- API reference ---------------------------------------------------------------------------
autosummary_generate = True
autosummary_ignore_module_all = False  # a module's __all__ is its public surface
autodoc_default_options = {"show-inheritance": True}
autodoc_typehints = "none"  # the numpydoc sections carry the types
autodoc_member_order = "bysource"

# numpydoc renders the docstrings; autosummary lists the members (no second list from numpydoc,
# which would document every method twice and warn about duplicate objects).
numpydoc_show_class_members = False
numpydoc_show_inherited_class_members = False
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = False

# -- HTML ------------------------------------------------------------------------------------
html_theme = "furo"
html_title = f"fitdf {release}"
html_static_path = []

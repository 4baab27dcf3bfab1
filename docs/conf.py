"""Sphinx configuration of the kapitza site (``docs/``).

Build (README): ``python -m sphinx -E -j auto -W --keep-going -b html docs docs/_build/html``.
Warnings are errors; the guide's examples run during the build (``_ext/executed_examples``);
the API pages are written from the packages' ``__all__`` at every build (``_ext/api_pages``,
into ``docs/api/``, which git ignores); the notebooks are executed by MyST-NB (their outputs
are not kept in git).
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(DOCS / "_ext"))
sys.path.insert(0, str(ROOT))  # this tree's packages, installed or not
os.environ.setdefault("MPLBACKEND", "Agg")

import kapitza  # noqa: E402  (after the path)

# numpydoc drops a section it does not know ("Closed forms", "Damping") from the page and
# only says so on stderr: an error here, naming the docstring (rename it "Notes")
warnings.filterwarnings("error", message="Unknown section", category=UserWarning)

project = "kapitza"
author = "the kapitza developers"
copyright = "2026, the kapitza developers"
version = release = kapitza.__version__

extensions = [
    "sphinx.ext.autodoc",
    "numpydoc",
    "numpydoc_template",  # after numpydoc: its template compiled once, not per docstring
    "myst_nb",
    "api_pages",
    "absolute_values",
    "cli_reference",
    "executed_examples",
    "page_writing",  # the navigation column and the search stems: once, not per page
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "jupyter_execute", "**.ipynb_checkpoints", "_ext"]
templates_path: list[str] = []

# --- API pages --------------------------------------------------------------------------
autodoc_typehints = "signature"
autodoc_typehints_format = "short"
autodoc_member_order = "bysource"
autodoc_preserve_defaults = True  # "omega=2 * math.pi * 60", not 376.99111843077515
# the packages write no "# type:" comments, so autodoc need not parse every function's source
# to look for them (0.3 CPU-s of a build)
autodoc_use_type_comments = False
numpydoc_show_class_members = False  # autodoc's :members: lists them, once
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False  # "float or ndarray" stays text (no intersphinx)
numpydoc_validation_checks: set[str] = set()

# --- MyST and the notebooks -------------------------------------------------------------
myst_enable_extensions = ["colon_fence"]
myst_heading_anchors = 3  # "#1-the-stability-window" as on GitHub
# the notebooks are stored without outputs and executed whenever they are read (-E: every
# build), so the site shows what the code computes now; an error fails the build
nb_execution_mode = "force"
nb_execution_timeout = 300
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_merge_streams = True

# --- HTML -------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"kapitza {release}"
html_static_path = ["_static"]
html_css_files = ["kapitza.css"]
# pages without a section of their own: no empty navigation column
html_sidebars = {page: [] for page in ("index", "cli", "changelog", "api-conventions", "tutorial")}
html_show_sourcelink = False
# the theme's light/dark switch starts from the reader's system setting (unset, the
# theme's script logs an error on every page)
html_context = {"default_mode": "auto"}
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "navbar_align": "left",
    "header_links_before_dropdown": 8,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}

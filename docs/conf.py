"""Sphinx configuration of the ldpipe documentation (MyST Markdown pages, a sphinx-gallery gallery).

Build: ``sphinx-build -W docs docs/_build/html`` (what tests/docs/test_docs.py runs). The gallery's
examples run while the site builds; ``LDPIPE_EXAMPLE_POINTS`` sets their grid size (the tests set
it small).
"""

from __future__ import annotations

import sys
from pathlib import Path

import ldpipe

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))

project = "ldpipe"
author = "the ldpipe developers"
copyright = "the ldpipe developers"
release = ldpipe.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    # MathJax served from the site itself, so formulas render offline and in the tests' browser
    "sphinx-mathjax-offline",
    "sphinx_gallery.gen_gallery",
    "schema_reference",
    "keyword_text",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "examples", "Thumbs.db", ".DS_Store"]
root_doc = "index"

myst_enable_extensions = ["colon_fence", "deflist", "dollarmath"]
myst_heading_anchors = 3

autodoc_typehints = "description"
autodoc_member_order = "bysource"
autosummary_generate = True
napoleon_google_docstring = False
napoleon_numpy_docstring = True

sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_",  # every example runs when the site builds
    "abort_on_example_error": True,
    "min_reported_time": 0,  # every example states its runtime
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
}

html_theme = "furo"
html_title = "ldpipe"
html_static_path = ["_static"]
html_logo = None

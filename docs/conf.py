"""Sphinx configuration of isoscope's documentation site: the user guide (Markdown, through myst-parser),
the API reference (autodoc + numpydoc from the public functions' docstrings) and a gallery of scripts
whose pictures isoscope renders offscreen while the site is built (sphinx-gallery).

    pip install -e ".[docs]" && sphinx-build -W -b html docs docs/_build/html
"""
from __future__ import annotations

import os

import isoscope

project = "isoscope"
author = "isoscope developers"
release = version = isoscope.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "examples", "python.ipynb", "gallery/*.ipynb", "gallery/*.py", "gallery/*.json",
                    "gallery/*.md5", "gallery/*.zip"]
myst_heading_anchors = 3
suppress_warnings = ["myst.header"]   # the guide's pages keep the README's heading levels

autosummary_generate = True
autodoc_typehints = "none"            # numpydoc's Parameters sections say the types
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
numpydoc_validation_checks = set()

sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_",
    "image_scrapers": ("matplotlib",),
    "download_all_examples": False,
    "remove_config_comments": True,
    "plot_gallery": os.environ.get("ISOSCOPE_DOCS_GALLERY", "True"),
}

html_theme = "pydata_sphinx_theme"
html_title = "isoscope"
html_static_path = []
html_theme_options = {"navigation_with_keys": False, "show_prev_next": False}

"""Sphinx configuration of ringsim's API reference, generated from the docstrings.

Build from the repository root, warnings as errors (CI does)::

    sphinx-build -W --keep-going -b html docs/api build/api
"""

import ringsim

project = "ringsim"
author = "ringsim developers"
release = ringsim.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
]
autosummary_generate = True
autosummary_imported_members = False
# Each object is documented where it is defined: a name a module re-exports in its
# ``__all__`` is not documented a second time there.
autodoc_default_options = {"members": True, "show-inheritance": True, "ignore-module-all": True}
autodoc_typehints = "description"
autodoc_member_order = "bysource"
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_rtype = False
# A class's "Attributes" section as fields of the class, not as a second description of
# attributes autodoc already documents (dataclass fields).
napoleon_use_ivar = True
# Docstrings name units in brackets after the type ("radius : float [m]"): the numpy
# parameter syntax reads that as a type expression, which is what the reader wants to see.
napoleon_preprocess_types = False
exclude_patterns = ["_build", "generated/*.tmp"]
html_theme = "alabaster"
html_title = f"ringsim {release} API reference"
nitpicky = False
# A short name in a docstring's type ("Scenario", "radius") can match several documented
# objects; Sphinx then links the first, which is what the reader wants.
suppress_warnings = ["ref.python"]


def _plain_bars(app, what, name, obj, options, lines):
    """Docstrings write |x| for an absolute value; reST would read a substitution."""
    for i, line in enumerate(lines):
        if "|" in line and not line.lstrip().startswith(("+", "| ")):
            lines[i] = line.replace("|", "\\|")


def setup(app):
    app.connect("autodoc-process-docstring", _plain_bars)

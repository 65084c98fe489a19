"""The validation of ringsim against published ring physics: scripts of the repository.

Run from the repository root with ``python -m validation COMMAND`` (``__main__``: the one
runner; ``--help`` lists the commands).  Modules:

* ``common``: what the scripts share (``Sizes``, ``Comparison``, ``CaseResult``,
  ``run_cached``, ``sheet_scenario``);
* ``case5_rebound_example``: the reference case of the validation ladder still run as a
  script (cases 1 to 4 are study files under ``studies/``, case 6 is
  ``tests/test_dilley_figures.py``);
* ``ladder``: runs the cases and writes the report (``python -m validation ladder``);
* ``encounters``: the straight-path prediction of multiple encounters in a step (line
  mode's check, ``studies/validation-line-mode`` and ``tests/test_line_mode.py``);
* ``cooling``: the homogeneous cooling of rough spheres in a periodic box;
* ``render``: the Markdown of ``docs/validation.md``.

The validation is not part of the installed package: it reads ``scenarios/`` and writes
``docs/`` and ``runs/`` of the repository.  The tests import it with the repository root on
the path (``pythonpath`` in pyproject.toml).  Importing this package imports nothing else.
"""

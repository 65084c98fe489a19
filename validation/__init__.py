"""The validation of ringsim against published ring physics: scripts of the repository.

Run from the repository root with ``python -m validation COMMAND`` (``__main__``: the one
runner; ``--help`` lists the commands).  Modules:

* ``common``: what the cases share (``Sizes``, ``Comparison``, ``CaseResult``,
  ``run_cached``, ``sheet_scenario``, the energy balance of a sheet);
* ``case1_constant_eps``, ``case3_bridges_identical`` and ``case5_rebound_example``: the
  reference cases of the validation ladder still run as scripts, one module each (cases 2
  and 4 are study files under ``studies/``, case 6 is ``tests/test_dilley_figures.py``);
* ``ladder``: runs the cases and writes the report (``python -m validation ladder``);
* ``line_mode``: line-mode collision detection against the small-dt tree reference, with
  ``encounters``, the straight-path prediction of multiple encounters it reports;
* ``friction_ring`` and ``cooling``: a ring patch of rough spheres, and the homogeneous
  cooling of rough spheres in a periodic box;
* ``render``: the Markdown of ``docs/validation.md``.

The validation is not part of the installed package: it reads ``scenarios/`` and writes
``docs/`` and ``runs/`` of the repository.  The tests import it with the repository root on
the path (``pythonpath`` in pyproject.toml).  Importing this package imports nothing else.
"""

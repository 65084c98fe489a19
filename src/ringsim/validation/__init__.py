"""The validation of ringsim against published ring physics, as a package.

Modules:

* ``common``: what the cases share (``Sizes``, ``Comparison``, ``CaseResult``,
  ``run_cached``, ``sheet_scenario``, the energy balance of a sheet);
* ``case1_constant_eps`` ... ``case6_dilley_figures``: the six reference cases of the
  validation ladder (issue 6), one module each;
* ``line_mode``: line-mode collision detection against the small-dt tree reference
  (issue 7);
* ``render``: the Markdown of ``docs/validation.md``;
* ``ladder``: runs the cases and writes the report (``python -m ringsim.validation``, the
  same as ``python analysis/validation.py``).

The validation runs on a source checkout: it reads ``scenarios/`` and writes ``docs/`` and
``runs/`` of the repository.  Importing this package imports nothing else.
"""

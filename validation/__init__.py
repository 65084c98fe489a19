"""The validation of ringsim against published ring physics: scripts of the repository.

Run from the repository root with ``python -m validation COMMAND`` (``__main__``: the one
runner; ``--help`` lists the commands).  Modules:

* ``common``: the repository's root;
* ``encounters``: the straight-path prediction of multiple encounters in a step (line
  mode's check, ``studies/validation-line-mode`` and ``tests/test_line_mode.py``);
* ``cooling``: the homogeneous cooling of rough spheres in a periodic box.

The validation is not part of the installed package: it reads ``scenarios/`` and writes
``docs/`` and ``runs/`` of the repository.  The tests import it with the repository root on
the path (``pythonpath`` in pyproject.toml).  Importing this package imports nothing else.
"""

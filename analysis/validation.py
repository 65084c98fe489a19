"""The validation ladder (issue 6): ``python analysis/validation.py [--quick] [--cases N ...]
[--report-only]``.  The cases live in the package ``ringsim.validation``; this script is the
same as ``python -m ringsim.validation`` (see ``ringsim/validation/ladder.py``)."""

from ringsim.validation.ladder import main

if __name__ == "__main__":
    raise SystemExit(main())

"""The validation of ringsim against published ring physics: the one script of the
repository not yet converted to a study (``aggregation``: where the rings start to
aggregate, ``python -m validation.aggregation OUT_DIR``).

The validation is not part of the installed package.  Importing this package imports
nothing else.
"""

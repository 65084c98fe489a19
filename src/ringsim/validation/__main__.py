"""``python -m ringsim.validation``: the validation ladder (see ``ringsim.validation.ladder``)."""

from ringsim.validation.ladder import main

raise SystemExit(main())

"""Line-mode collision detection against the small-dt tree reference (issue 7):
``python analysis/line_mode_validation.py run|report|all [--cases ...] [--replicas 6]``.
The validation lives in ``ringsim.validation.line_mode``; this script is the same as
``python -m ringsim.validation.line_mode``."""

from ringsim.validation.line_mode import main

if __name__ == "__main__":
    main()

"""Build the native collision resolver against the installed REBOUND's headers.

All metadata lives in pyproject.toml; this file only exists because the
include directory of ``rebound.h`` is known only once REBOUND is installed
(the rebound wheel ships it under ``site-packages/src/``).
"""

import os

import rebound
from setuptools import Extension, setup

REBOUND_INCLUDE = os.path.join(os.path.dirname(os.path.dirname(rebound.__file__)), "src")
if not os.path.isfile(os.path.join(REBOUND_INCLUDE, "rebound.h")):
    raise RuntimeError(f"rebound.h not found in {REBOUND_INCLUDE}; is rebound==5.2.2 installed?")

setup(
    ext_modules=[
        Extension(
            "ringsim._resolver",
            sources=["ringsim/csrc/rs_resolver.c", "ringsim/csrc/rs_sheet_detect.c",
                     "ringsim/csrc/rs_gravity.c", "ringsim/csrc/rs_setup.c",
                     "ringsim/csrc/rs_p3m.c"],
            include_dirs=[REBOUND_INCLUDE],
            libraries=["m"],
            extra_compile_args=["-O3", "-std=c99", "-fno-fast-math", "-ffp-contract=off"],
        )
    ]
)

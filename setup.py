"""Build the native collision resolver against the installed REBOUND's headers.

All metadata lives in pyproject.toml; this file only exists because the
include directory of ``rebound.h`` is known only once REBOUND is installed
(the rebound wheel ships it under ``site-packages/src/``), and because OpenMP is used
only where the compiler supports it.
"""

import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile

import rebound
from setuptools import Extension, setup

REBOUND_INCLUDE = os.path.join(os.path.dirname(os.path.dirname(rebound.__file__)), "src")
if not os.path.isfile(os.path.join(REBOUND_INCLUDE, "rebound.h")):
    raise RuntimeError(f"rebound.h not found in {REBOUND_INCLUDE}; is rebound==5.2.2 installed?")

# One source a line (easy to merge).
SOURCES = [
    "src/ringsim/csrc/rs_resolver.c",
    "src/ringsim/csrc/rs_sheet_detect.c",
    "src/ringsim/csrc/rs_sheet_classes.c",
    "src/ringsim/csrc/rs_gravity.c",
    "src/ringsim/csrc/rs_setup.c",
    "src/ringsim/csrc/rs_p3m.c",
    "src/ringsim/csrc/rs_sei.c",
    "src/ringsim/csrc/rs_stop.c",
]

OPENMP_FLAGS = ["-fopenmp"]


def openmp_works() -> bool:
    """True if the C compiler compiles and links a program with ``-fopenmp``.

    ``RINGSIM_NO_OPENMP=1`` builds without it.  Without OpenMP the sheet detector runs on
    one thread whatever ``integration.threads`` says (the results are the same).
    """
    if os.environ.get("RINGSIM_NO_OPENMP", "") not in ("", "0"):
        return False
    compiler = (sysconfig.get_config_var("CC") or "cc").split()[0]
    if shutil.which(compiler) is None:
        return False
    program = "#include <omp.h>\nint main(void){ return omp_get_max_threads() > 0 ? 0 : 1; }\n"
    with tempfile.TemporaryDirectory() as tmp:
        source = os.path.join(tmp, "openmp_check.c")
        with open(source, "w") as f:
            f.write(program)
        try:
            done = subprocess.run([compiler, *OPENMP_FLAGS, source, "-o",
                                   os.path.join(tmp, "openmp_check")],
                                  capture_output=True, check=False, timeout=60)
        except (OSError, subprocess.SubprocessError):
            return False
    return done.returncode == 0


if openmp_works():
    PARALLEL = OPENMP_FLAGS
else:
    PARALLEL = ["-Wno-unknown-pragmas"]    # the omp pragmas are then ignored, on purpose
    sys.stderr.write("ringsim: the C compiler has no OpenMP; building the sheet detector "
                     "for one thread\n")

setup(
    ext_modules=[
        Extension(
            "ringsim._resolver",
            sources=SOURCES,
            include_dirs=[REBOUND_INCLUDE],
            libraries=["m"],
            extra_compile_args=["-O3", "-std=c99", "-fno-fast-math", "-ffp-contract=off",
                                *PARALLEL],
            extra_link_args=[flag for flag in PARALLEL if flag in OPENMP_FLAGS],
        )
    ]
)

"""For tests and benchmarks (nothing of the library imports it).

* ``twins``: the pure-Python twins of the C code, the resolver
  (`PythonReferenceResolver`, ``sim.collision_resolve = twin``) and the overlap count of
  the outputs (`count_overlaps_numpy`), and `run_file_datasets`, with which tests compare
  run files bit for bit;
* ``gravity``: the self-gravity harness, random sheets in REBOUND with the tree or P3M,
  their accelerations and their errors against the converged image sum;
* ``resume``: `assert_resumes_bit_for_bit`, a run in one go against the same run stopped
  and resumed, and `assert_same_datasets`, two run files dataset by dataset;
* ``cooling``: the homogeneous cooling of a gas of rough spheres in a periodic box
  (`cool_rough_gas`), the reference of the two-temperature theory of rough spheres;
* ``synthetic_restitution``: the synthetic restitution measurements of the bundled
  ``ringsim fit`` example (`hatzes_like_csv`, `write_hatzes_like`).

Every name is importable from ``ringsim.testing`` itself.
"""

from ringsim.testing.cooling import CoolingRun, cool_rough_gas
from ringsim.testing.gravity import (
    DEFAULT_OPENING_ANGLE,
    DEFAULT_SOFTENING_FRACTION,
    accelerations,
    force_errors,
    p3m_simulation,
    random_sheet,
    reference_for,
    simulation_reference,
    tree_accelerations,
    tree_simulation,
)
from ringsim.testing.resume import assert_resumes_bit_for_bit, assert_same_datasets
from ringsim.testing.synthetic_restitution import hatzes_like_csv, write_hatzes_like
from ringsim.testing.twins import (
    OVERLAP_CHUNK,
    PythonReferenceResolver,
    count_overlaps_numpy,
    run_file_datasets,
)

__all__ = [
    "CoolingRun",
    "DEFAULT_OPENING_ANGLE",
    "DEFAULT_SOFTENING_FRACTION",
    "OVERLAP_CHUNK",
    "PythonReferenceResolver",
    "accelerations",
    "assert_resumes_bit_for_bit",
    "assert_same_datasets",
    "cool_rough_gas",
    "count_overlaps_numpy",
    "force_errors",
    "hatzes_like_csv",
    "p3m_simulation",
    "random_sheet",
    "reference_for",
    "simulation_reference",
    "run_file_datasets",
    "tree_accelerations",
    "tree_simulation",
    "write_hatzes_like",
]

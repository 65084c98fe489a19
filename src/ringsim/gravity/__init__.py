"""The self-gravity solvers installed in REBOUND, one module each, behind one interface.

* ``base``: the interface (`GravitySolver`) and the C fields' function pointers;
* ``tree``: REBOUND's tree, one ring of ghost boxes and the field of the sheet beyond them;
* ``p3m``: ringsim's shear-periodic P3M solver;
* ``slab``: the vertical field of the horizontally averaged layer only;
* ``registry``: the solvers by name (`SOLVERS`) and what the engine asks of them
  (`install_gravity`, the scenario's arguments, the run file's attributes).

Each solver's name and scenario keys are declared in ``ringsim.physics.gravity_solvers``
(the scenario reader validates them from there without importing REBOUND).
"""

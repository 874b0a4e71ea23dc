"""The compiled inner loop: forces on the node chain and leapfrog time stepping.

Discretisation (see docs in `solver/hose.py`): nodes 0..nh are the ends of the nh
rigid hose elements, node 0 at the tow point (reel exit). With a drogue, node nh+1
is the drogue's centre of mass, joined to the hose end (the hinge, node nh) by a
stiff link: element nh. Element e joins nodes e and e+1.

Everything here works on flat arrays and a scalar parameter vector `P` (indices
in `solver.kernel.layout`) so that numba compiles it once; the Python side (`solver.integrate`, `solver.stepper`)
prepares the arrays, handles the reel's remeshing and turns codes into errors.
"""
# what the Python side calls: the force routine (statics, linearisation), the
# crossflow drag law (statics), the table lookup (stepper), the time loop
from solver.kernel.forces import _cdn, compute_forces  # noqa: F401
from solver.kernel.layout import *  # noqa: F401,F403
from solver.kernel.steps import _interp_table, drum_radius_inertia, run_steps  # noqa: F401

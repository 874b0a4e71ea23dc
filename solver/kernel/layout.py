"""The kernel's scalar parameter vector `P` (index of each entry), the layout of
its `reel` array, its return codes and the remeshing band."""

# ---- indices into the scalar parameter vector P -------------------------------------
P_RHO = 0          # air density, kg/m^3
P_NU = 1           # kinematic viscosity, m^2/s
P_GX, P_GY, P_GZ = 2, 3, 4   # gravity vector, m/s^2
P_DIAM = 5         # hose outer diameter, m
P_CA0 = 6          # skin-friction coefficient on the wetted area
P_CDN = 7          # crossflow drag coefficient when regimes are off
P_CDN_REGIMES = 8  # 1: Eq. 7 Reynolds-number regimes, 0: constant P_CDN
P_HOSE_DRAG = 9    # scale on hose crossflow and skin friction (1 = baseline)
P_HAS_DROGUE = 10
P_CDA = 11         # drogue drag coefficient x area, m^2
P_CLA = 12         # drogue lift coefficient x area, m^2 (already scaled)
P_CP_FRAC = 13     # centre of pressure position along the link / link length
P_HINGE_FREE = 14  # free-play half angle, rad
P_HINGE_KPEN = 15  # penalty stiffness beyond the free play, N m/rad
P_HINGE_C = 16     # hinge viscous damping, N m s/rad
P_HINGE_FRIC = 17  # hinge Coulomb friction torque, N m
P_CLAMP = 18       # 1: element 0 is clamped in direction P_CLAMP_DIR at the tow point
P_CLAMP_DX, P_CLAMP_DY, P_CLAMP_DZ = 19, 20, 21
P_CLAMP_K = 22     # N m/rad
P_CLAMP_C = 23     # N m s/rad
P_END_MODE = 24    # 1: the last node follows the end table between P_END_ON and P_END_OFF
P_END_ON = 25
P_END_OFF = 26
P_REEL_MODE = 27   # 0 locked, 1 prescribed table, 2 drum with torque law
P_MU = 28          # hose mass per length incl. fuel, kg/m
P_EA0 = 29         # axial stiffness x length of the reel-exit element, N
P_ETA_A0 = 30      # axial damping x length of the reel-exit element, N s
P_EI1 = 31         # bending stiffness x length at joint 1, N m^2
P_ETA_B1 = 32      # bending damping x length at joint 1, N m^2 s
P_L_NOM = 33       # nominal element length, m (remeshing thresholds)
P_DRUM_R0 = 34     # empty drum radius, m
P_DRUM_W = 35      # drum width, m
P_DRUM_I0 = 36     # empty drum inertia, kg m^2
P_HOSE_TOTAL = 37  # total hose length (outside + wound), m
P_TORQUE_LAW = 38  # 0 constant torque, 1 constant tension
P_TORQUE = 39      # N m (law 0) or tension N (law 1)
P_VMAX = 40        # divergence threshold on any node speed, m/s
P_NE_MIN = 41      # fewest hose elements remeshing may leave
P_HOSE_REST_SUM = 44  # sum of rest lengths of hose elements 1..nh-1 (element 0 takes the rest)
P_EXTRA_MASS0 = 45    # mass lumped on node 1 besides its half elements (normally 0)
P_REEL_HOLD = 46      # reel drive hold-back b, N s/m at the drum rim (0: none; `_drive_hold`)
P_REEL_LAG = 47       # first-order lag of the drive's speed reference, s
P_END_K = 48   # probe coupling stiffness, N/m (0: the end follows its table rigidly)
P_END_C = 49   # probe coupling damping, N s/m
NP = 50

# the drive hold-back's state in the `reel` array (after the 10 bookkeeping slots):
# the lagged speed reference, the ring position, then a ring of past payout speeds
# whose length is the dead time in steps (`solver.chain.reel_state` sizes it)
REEL_FILT = 10
REEL_RING_POS = 11
REEL_RING = 12

# ---- kernel return codes ----------------------------------------------------------
OK = 0
NONFINITE = 1
OVERSPEED = 2
REMESH_GROW = 3
REMESH_SHRINK = 4
REEL_LIMIT = 5

# the reel-exit element is split above REMESH_MAX and merged below REMESH_MIN
# nominal lengths; split and merge both land inside the band
REMESH_MIN = 0.75
REMESH_MAX = 1.75

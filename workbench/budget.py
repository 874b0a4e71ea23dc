"""What a run will cost, estimated from the model before it starts, and the
limits beyond which it is refused (exit 2) instead of filling the disk or
running for hours.

The recorded result holds, per sample, position, velocity (3 each) and
tension (1) of every node: 7 float64 channels a node, plus ~25 scalars. The
integration costs about NS_PER_NODE_STEP per node and step: measured 57 ns on
the 40-element demo case (one core of the development machine); the estimate
takes 200 ns, so a slower machine is still inside it.
"""
from __future__ import annotations

from solver.model import Model
from workbench.errors import InputError

MAX_OUTPUT_BYTES = 2e9        # what one run may hold in memory and write: 2 GB
MAX_WALL_S = 1800.0           # a single run estimated longer than 30 min is refused
MAX_DURATION_S = 3600.0       # longest simulated span of a run (an hour of flight)
NS_PER_NODE_STEP = 200.0
CHANNELS_PER_NODE = 7
SCALARS_PER_SAMPLE = 25


def check_run(model: Model, duration_s: float, record_dt_s: float, where: str) -> dict:
    """Refuse a run whose record step is below the solver's step, whose span is
    not positive or over MAX_DURATION_S, or whose estimated output or wall time
    passes MAX_OUTPUT_BYTES / MAX_WALL_S; `where` names the case (or option).
    Returns the estimate {"bytes", "wall_s", "samples", "steps"}."""
    if not 0.0 < duration_s <= MAX_DURATION_S:
        raise InputError(f"{where}: run duration {duration_s!r} s must lie in (0, {MAX_DURATION_S:g}] s")
    dt = model.stable_step()
    if record_dt_s < dt:
        raise InputError(f"{where}: [run] record_dt_s {record_dt_s:g} s is below the solver's stable step "
                         f"{dt:.3g} s for this model (must be >= it: finer records hold nothing new)")
    samples = duration_s / record_dt_s + 1
    nodes = model.n_elements + 3     # tow point, hose nodes, drogue
    size = samples * (nodes * CHANNELS_PER_NODE + SCALARS_PER_SAMPLE) * 8
    if size > MAX_OUTPUT_BYTES:
        raise InputError(f"{where}: the run would record {size / 1e9:.3g} GB ({samples:.3g} samples x {nodes} "
                         f"nodes; limit {MAX_OUTPUT_BYTES / 1e9:g} GB): raise record_dt_s or shorten the run")
    steps = duration_s / dt
    wall = steps * nodes * NS_PER_NODE_STEP * 1e-9
    if wall > MAX_WALL_S:
        raise InputError(f"{where}: the run is estimated at {wall / 60:.3g} min ({steps:.3g} steps of "
                         f"{dt:.3g} s x {nodes} nodes; limit {MAX_WALL_S / 60:g} min): fewer elements or a "
                         f"shorter run")
    return {"bytes": size, "wall_s": wall, "samples": samples, "steps": steps}

"""SimulationResult: tables and plots from a short run."""
import numpy as np
import pandas as pd

from solver.drogue import DrogueProperties
from solver.integrate import simulate
from solver.statics import solve_static

from tests.solver.test_towed import towed_model


def test_to_pandas_and_plot():
    d = DrogueProperties(mass=27.0, diameter=0.68, cd=0.82, cl=0.1, cp_aft_of_hinge=0.4)
    m = towed_model(n=10, EI=50.0, ca0=0.004, drogue=d, bending_damping=2.0, axial_damping=300.0)
    r = simulate(m, 1.0, solve_static(m), record_dt=0.05)
    df = r.to_pandas()
    assert isinstance(df, pd.DataFrame)
    assert df.index.name == "t_s"
    assert len(df) == len(r.t) == 20
    for col in ("end_x_m", "end_z_m", "tow_force_x_N", "reel_length_m", "hinge_angle_deg"):
        assert col in df and np.all(np.isfinite(df[col]))
    np.testing.assert_allclose(df["end_x_m"].to_numpy(), r.drogue_xyz[:, 0])
    for kind in ("summary", "shape", "end"):
        fig = r.plot(kind)
        assert fig.axes
    np.testing.assert_allclose(r.hose_points(0)[0], [0.0, 0.0, 0.0], atol=1e-12)

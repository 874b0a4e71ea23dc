"""The objective-test table's validation uncertainty (ASME V&V 20): the GCI,
the root sum of squares, and u_num / u_input carried from a run's metrics to
the table's quantities."""
from numpy.testing import assert_allclose

from workbench.report.document import Cell
from workbench.report.objective import objective_tables, rss
from workbench.validation import GCI_COVERAGE, gci

BOUNDS = {"frequency": 0.5, "damping": 2.0}


def test_gci_is_roaches_two_grid_index():
    # by hand: Fs 3, r 2, p 2: 3 * |1.00 - 1.06| / (4 - 1) = 0.06
    assert_allclose(gci(1.00, 1.06, 2.0), 0.06, rtol=1e-12)
    # r 1.5: 3 * 0.5 / (2.25 - 1) = 1.2; the order and factor given: 1.25 * 0.5 / (1.5 - 1) = 1.25
    assert_allclose(gci(10.0, 10.5, 1.5), 1.2, rtol=1e-12)
    assert_allclose(gci(10.0, 9.5, 1.5, order=1.0, safety=1.25), 1.25, rtol=1e-12)
    assert gci(2.0, 2.0, 2.0) == 0.0


def test_u_val_is_the_root_sum_of_squares_leaving_out_the_unmeasured():
    assert_allclose(rss(0.3, 0.4, 1.2), 1.3, rtol=1e-12)     # 0.09 + 0.16 + 1.44 = 1.69
    assert_allclose(rss(0.3, None, 0.4), 0.5, rtol=1e-12)
    assert rss(None, None) == 0.0


def _doublet_case(u_num_f, u_input_z):
    m = {"drogue_frequency_hz_log": 0.50, "drogue_frequency_hz_sim": 0.52,
         "drogue_steady_z_m_log": -5.0, "drogue_steady_z_m_sim": -5.3}
    run = {"variant": "baseline", "log": "PD-1", "held_out": True, "metrics": m,
           "uncertainty": {"u_num": {"drogue_frequency_hz_sim": u_num_f, "drogue_steady_z_m_sim": 0.0},
                           "u_input": {"drogue_steady_z_m_sim": u_input_z}}}
    return {"kind": "pitch_doublet", "runs": [run], "gates": []}


def _rows(case):
    (table,) = objective_tables(case, BOUNDS)
    head = table.header
    return {r[1]: dict(zip(head, r)) for r in table.rows}


def test_flight_u_num_and_u_input_come_from_the_runs_study():
    rows = _rows(_doublet_case(u_num_f=0.004, u_input_z=0.4))
    period = rows["period (s)"]
    # period = 1/f: u_num of the period is u_f / f^2 to first order (0.004 / 0.52^2 = 0.01479),
    # the step 1/0.52 - 1/0.524 = 0.014680 differs from it by u_f / f = 0.8 %
    assert_allclose(period["u_num"], 1 / 0.52 - 1 / 0.524, rtol=1e-12)
    assert period["u_input"] is None and period["u_D"] is None       # not measured, one log
    assert_allclose(period["u_val"], period["u_num"], rtol=1e-12)
    z = rows["steady drogue z (m)"]
    assert_allclose(z["E = S − D"], -0.3, rtol=1e-12)
    # carried through S's accessor, (-5.3 + 0.4) - (-5.3): exact to rounding
    assert z["u_num"] == 0.0
    assert_allclose([z["u_input"], z["u_val"]], [0.4, 0.4], rtol=1e-12)
    # |E| 0.3 <= u_val 0.4: validated to the level of u_val; with u_input 0.2 it is not
    assert isinstance(z["|E| ≤ u_val"], Cell) and z["|E| ≤ u_val"].text == "yes"
    z = _rows(_doublet_case(u_num_f=0.004, u_input_z=0.2))["steady drogue z (m)"]
    assert z["|E| ≤ u_val"].text == "no"


def test_a_run_without_a_study_is_a_bench_ringdown_and_takes_the_verification_bound():
    m = {"frequency_measured_hz": 2.0, "frequency_simulated_hz": 2.1, "damping_measured": 0.05,
         "damping_simulated": 0.06}
    case = {"kind": "ringdown_bending", "gates": [],
            "runs": [{"variant": "baseline", "log": "KC130 bending 70F", "held_out": True, "metrics": m}]}
    rows = _rows(case)
    # 0.5 % of the simulated period 1/2.1, 2 % of the simulated damping 0.06
    assert_allclose(rows["period (s)"]["u_num"], 0.005 / 2.1, rtol=1e-12)
    assert_allclose(rows["damping ratio (-)"]["u_num"], 0.02 * 0.06, rtol=1e-12)


def test_a_failed_study_leaves_u_num_unmeasured_not_the_bench_bound():
    case = _doublet_case(0.0, 0.0)
    case["runs"][0]["uncertainty"] = {"error": "the half-element run: diverged"}
    assert _rows(case)["period (s)"]["u_num"] is None
    assert GCI_COVERAGE == 2.0     # the glossary's "u_num = GCI / 2"

"""Hose-and-drogue aerial refueling simulation and validation workbench.

The Python API (`workbench.api`), for notebooks and scripts:

    import workbench
    case = workbench.load_case("cases/kdc10_trail.toml")
    out = workbench.run(case, log="flighttest/logs/flight/TR-KDC10-E7.mcap", duration=2.0)
    out.to_pandas(); out.plot()
    outcomes = workbench.validate(["cases/g3_pitch_doublets.toml"])
    diagnosis = workbench.diagnose(["flighttest/logs/flight/PD-G3-1.mcap", ...])
"""
from workbench.api import diagnose, load_case, run, validate

__all__ = ["load_case", "run", "validate", "diagnose"]

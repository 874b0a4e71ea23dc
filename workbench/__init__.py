"""Hose-and-drogue aerial refueling simulation and validation workbench.

The Python API (`workbench.api`), for notebooks and scripts:

    import workbench
    case = workbench.load_case("cases/kdc10_trail.toml")
    out = workbench.run(case, log="flighttest/logs/flight/TR-KDC10-E7.mcap", duration=2.0)
    out.to_pandas(); out.plot()
    outcomes = workbench.validate(["cases/g3_pitch_doublets.toml"])
    diagnosis = workbench.diagnose(["flighttest/logs/flight/PD-G3-1.mcap", ...])

`run` and `validate` share their names with the modules that implement them
(`workbench.run`, `workbench.validate`), which tests and code address by
dotted path; so that both work, those two modules are made callable here:
`workbench.run(...)` calls `workbench.api.run(...)`.
"""
import types

from workbench import api
from workbench import run, validate  # the modules, already imported by api
from workbench.api import diagnose, load_case

__all__ = ["load_case", "run", "validate", "diagnose"]


class _VerbModule(types.ModuleType):
    """A module that, called, runs the API function of its name (see above)."""

    def __call__(self, *args, **kwargs):
        return getattr(api, self.__name__.rpartition(".")[2])(*args, **kwargs)


for _module in (run, validate):
    _module.__class__ = _VerbModule

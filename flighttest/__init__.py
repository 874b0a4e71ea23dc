"""Flight and bench test records: contract, reader/writer, measurements.

The package takes nothing from the solver but its unit factors
(`solver.units`, a leaf module of constants): records are measured on their own
(`analyze_record`) and compared with simulations through the same reader
(`write_record` stores a simulation run in the contract).

Modules: `schema` (the contract as data, physical ranges, the typed test
card), `record` (`FlightRecord`, `LogError`), `reader` (the one door for
logs) over `container` (MCAP walk), `messages` (message checks, shared with
`writer`) and `plausibility` (what the values show together), `writer`,
`metrics` (measurements on arrays, by concern), `analyze` (one record on its
own), `residual` (the one comparison of a log with a simulated record:
components tagged by channel, station, phase, segment and band; its
signature components of timing and shape in `signatures`), `compare`
(validation's metrics from it, with the residual, as a `Comparison`).  Modules import each other by
name (`from .schema import ...`), never through this package, so importing
any of them cannot loop back here.
"""
from .analyze import analyze_record
from .reader import read_record, read_record_bytes
from .record import FlightRecord, LogError, make_record
from .writer import write_record
from .schema import REQUIRED_TOPICS, TEST_KINDS, TOPICS, TestInfo

__all__ = [
    "FlightRecord", "LogError", "TestInfo", "TOPICS", "TEST_KINDS", "REQUIRED_TOPICS",
    "read_record", "read_record_bytes", "write_record", "make_record", "analyze_record",
]

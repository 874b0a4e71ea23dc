"""The proving ground: flight logs made by physics the diagnosis did not write.

`generate` makes one log of the shared logs' kinds (doublet, trail,
engagement) from a model that differs from the diagnosis's in form (finer
hose, another structural damping law, scattered bench and data-sheet
properties, another drogue reference point, a wake of another shape) with
one or several library effects switched on and a nuisance layer (light
turbulence, tracker noise, dropouts and clock jitter). `campaign` runs the
diagnosis blind on such logs and scores it.

The diagnosis never imports this package: the two share only the log
contract (flighttest's writer and reader, the schema). `generate` imports no
part of `workbench.diagnosis`; `campaign` is the harness that uses both.
"""

# The campaigns' families (`campaign.plan`), here where the command line reads
# them without importing the harness: one effect per log, two or three at
# once, one near the instruments' noise, none withheld.
FAMILIES = ("single", "multi", "subtle", "null")

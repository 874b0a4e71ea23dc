"""Hose property tables from the bench ring-down records (paper III.B, IV.A).

Modules by concern, in pipeline order: `measure` (ring-down records ->
frequency, damping ratio, temperature), `rig` (the bench rigs as solver models
and their first linear mode), `tune` (element constants that reproduce the
measured mode; derived hoses), `verify` (paper Fig. 9 time simulation and
interpolation checks), `build` (the whole build, `build_properties`), `store`
(the JSON document on disk, `load_library`) and `report` (its figures).
"""

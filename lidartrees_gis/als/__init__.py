"""Airborne laser scanning: surfaces (DSM, DTM, CHM), tree tops and crowns, and the file-level
chains that run them over an area in tiles (docs/ARCHITECTURE.md); plantation mode's methods
are in :mod:`lidartrees_gis.plantation`.

Methods (pure functions over numpy arrays): :mod:`.surfaces`, :mod:`.chm`, :mod:`.smooth`,
:mod:`.tops`, :mod:`.crowns`, :mod:`.trees`, :mod:`.metrics`. Per tile:
:mod:`.area` (the plan), :mod:`.tile` (the tasks), :mod:`.sinks` (the merge). Chains:
:mod:`.chain` (trees), :mod:`.rasters` (grid, chm), :mod:`.compare` (seed 000's Table 1).
"""

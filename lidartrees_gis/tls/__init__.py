"""Terrestrial scans of single trees: the Dmax trunk filter (Buck et al. 2014, seed 004) and
the roots / stem / canopy profile segmentation (Queiroz 2017, seed 002)."""

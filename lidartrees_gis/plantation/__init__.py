"""Plantation mode: the planting lattice under the tops or in the canopy (``stocking``,
``spectrum``, ``canopy_lattice``), the planting positions and their statuses (``positions``),
the stocking and its interval (``stockreport``) and the stands (talhões: ``stands``). Pure
functions over arrays; the ALS chain (``lidartrees_gis.als``) calls them tile by tile."""

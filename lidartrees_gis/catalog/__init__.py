"""Point files as one acquisition, and the tiles it is processed in (lidR's LAScatalog, lasR's
pipeline): what the per-tile functions of every capability run on.

* :mod:`.inputs` — what the user names (files, folders, globs, lists, .vpc, ept.json) to files;
* :mod:`.catalog` — :class:`Catalog` (files, bounds, counts, CRS) and :func:`make_tiles`;
* :mod:`.source` — :class:`TileSource`, the points of one buffered tile, with a read cache;
* :mod:`.runner` — :class:`TileRunner`: tasks in this process or on Dask;
* :mod:`.mosaic` — :class:`MosaicWriter`, GeoTIFF windows written as tiles finish;
* :mod:`.info` — what a point source holds (``lidartrees info``).
"""

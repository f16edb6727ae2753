"""``lidartrees --compile``: compile and cache every numba kernel once, right after installing.

numba compiles a kernel the first time it runs and caches it on disk (beside the package, or
in ``NUMBA_CACHE_DIR``); without this step the first command after an install pays for it (bcts_1
``trees`` 12.3 s the first time, 4.4 s after). Running the main jobs once on a small synthetic
stand (points, ground filter, CHM of every kind, trees with crowns) compiles every kernel with
the argument types the commands use.
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path


def compile_kernels(progress=None) -> dict:
    """Run the chains once on a 40 x 40 m synthetic stand so that numba compiles and caches
    their kernels; returns the seconds it took and whether numba is in use."""
    import pyproj

    from . import _accel
    from .als.chain import trees_run
    from .als.rasters import chm_run
    from .als.surfaces import SurfaceOptions
    from .catalog.catalog import TilingOptions
    from .ground.tiled import ground_run
    from .io.lasout import write_points
    from .io.output import OutputOptions
    from .progress import SubProgress, as_progress
    from .synthetic import CRS, StandParams, make_stand

    prog = as_progress(progress)
    t = time.perf_counter()
    if not _accel.HAVE_NUMBA:
        return {"numba": False, "seconds": 0.0}
    pts, _ = make_stand(StandParams(width=40.0, height=40.0, density=12.0))
    one = TilingOptions(workers=1)
    over = OutputOptions(overwrite=True)
    with tempfile.TemporaryDirectory(prefix="lidartrees-compile-") as d:
        f = Path(d) / "stand.laz"
        write_points(f, pts.x, pts.y, pts.z, crs=pyproj.CRS.from_user_input(CRS),
                     classification=pts.classification)
        steps = [
            lambda p: ground_run(f, Path(d) / "g.laz", dtm_out=Path(d) / "dtm.tif", tiling=one,
                                 out=over, progress=p),
            *[(lambda p, k=k: chm_run(f, Path(d) / f"chm_{k}.tif", tiling=one, out=over,
                                      surface=SurfaceOptions(chm=k), progress=p))
              for k in ("pitfree", "max", "tin")],
            lambda p: trees_run(f, Path(d) / "t.gpkg", tiling=one, out=over, progress=p),
        ]
        for i, step in enumerate(steps):
            step(SubProgress(prog, i / len(steps), (i + 1) / len(steps)))
    prog.update(1.0, "done")
    return {"numba": True, "seconds": round(time.perf_counter() - t, 1),
            "cached": _accel.kernels_cached()}

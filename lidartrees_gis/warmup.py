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


def compile_kernels(progress=None, every_method: bool = False) -> dict:
    """Run the chains once on a 40 x 40 m synthetic stand so that numba compiles and caches
    their kernels; returns the seconds it took and whether numba is in use. ``every_method``:
    the other crown methods too (treex, watershed), for :data:`KERNEL_LIST`."""
    import pyproj

    from . import _accel
    from .als.chain import trees_run
    from .als.rasters import chm_run
    from .als.surfaces import SurfaceOptions
    from .als.trees import TreeParams
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
            *[(lambda p, m=m: trees_run(f, Path(d) / f"t_{m}.gpkg", tiling=one, out=over,
                                        params=TreeParams(method=m), progress=p))
              for m in (("treex", "watershed") if every_method else ())],
        ]
        for i, step in enumerate(steps):
            step(SubProgress(prog, i / len(steps), (i + 1) / len(steps)))
    prog.update(1.0, "done")
    return {"numba": True, "seconds": round(time.perf_counter() - t, 1),
            "cached": _accel.kernels_cached()}


#: the modules whose numba kernels a wheel carries compiled (see :func:`compile_listed`)
KERNEL_MODULES = ("lidartrees_gis._accel", "lidartrees_gis._raster", "lidartrees_gis.tin",
                  "lidartrees_gis.als.crowns", "lidartrees_gis.als.metrics",
                  "lidartrees_gis.ground._kernels")
#: every kernel's argument types as the commands call it, one ``module name (types)`` a line;
#: written by ``python -m lidartrees_gis.warmup --list`` after :func:`compile_kernels`
KERNEL_LIST = Path(__file__).with_name("kernels.txt")


def _type_text(t) -> str:
    """A numba type as numba's signature strings spell it (``float64[:, ::1]``, ``int64``)."""
    from numba.core import types

    if isinstance(t, types.Array):
        if not t.mutable or not t.aligned:
            raise ValueError(f"kernel argument {t}: a read-only or unaligned array has no "
                             "signature text")
        dt = "boolean" if t.dtype == types.boolean else str(t.dtype)
        dims = [":"] * t.ndim
        if t.layout == "C":
            dims[-1] = "::1"
        elif t.layout == "F":
            dims[0] = "::1"
        return f"{dt}[{', '.join(dims)}]"
    return "boolean" if t == types.boolean else str(t)


def _dispatchers():
    import importlib

    from numba.core.registry import CPUDispatcher

    for m in KERNEL_MODULES:
        for name, v in sorted(vars(importlib.import_module(m)).items()):
            # the kernels the modules call (``*_nb``); the helpers they call are compiled into
            # them (alone, numba would list their literal-typed specialisations too)
            if isinstance(v, CPUDispatcher) and v.py_func.__module__ == m and name.endswith("_nb"):
                yield m, name, v


def kernel_signatures() -> list[str]:
    """The lines of :data:`KERNEL_LIST` for the kernels this process has compiled or loaded."""
    return sorted({f"{m} {name} ({', '.join(_type_text(t) for t in sig)})"
                   for m, name, d in _dispatchers() for sig in d.signatures})


def compile_listed(path=KERNEL_LIST) -> int:
    """Compile (and cache beside their modules) the kernels listed in ``path``, without running
    anything: the wheel's build does this (``_build.py``), so that the first run after
    ``pip install`` finds them compiled. Returns how many signatures were compiled."""
    import importlib

    from numba.core.sigutils import normalize_signature

    n = 0
    for line in Path(path).read_text().splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        mod, name, sig = line.split(" ", 2)
        args, _ = normalize_signature(sig)  # types, as numba's cache keys them (not the text)
        getattr(importlib.import_module(mod), name).compile(tuple(args))
        n += 1
    return n


if __name__ == "__main__":  # pragma: no cover - a developer's step, tested through its output
    import sys

    if sys.argv[1:] == ["--list"]:
        compile_kernels(every_method=True)
        KERNEL_LIST.write_text("# numba kernels the wheel carries compiled: python -m "
                               "lidartrees_gis.warmup --list\n"
                               + "\n".join(kernel_signatures()) + "\n")
    elif sys.argv[1:] == ["--build"]:
        print(f"{compile_listed()} kernel signatures compiled")
    else:
        sys.exit("usage: python -m lidartrees_gis.warmup --list | --build")

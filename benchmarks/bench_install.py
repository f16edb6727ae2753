"""The first run after a fresh install (issue 25): a new venv, ``pip install`` of this checkout
with no extras and no ``lidartrees --compile`` step, then ``lidartrees trees`` on bcts_1 three
times on one core (taskset, one thread): the first run against the later ones, and
``lidartrees --version``'s CPU.

The wheel pip builds carries the numba kernels compiled (``_build.py``); ``--no-precompile``
builds it without them (``LIDARTREES_NO_PRECOMPILE=1``), the first run then compiles them.

Usage: python benchmarks/bench_install.py [--out benchmarks/results/install.json] [--no-precompile]
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BCTS = ROOT.parent / "shared" / "data" / "lasR_bcts" / "bcts_1.laz"
ONE = ["taskset", "-c", "0"] if shutil.which("taskset") else []
THREADS = {k: "1" for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                            "NUMBA_NUM_THREADS")}


def timed(cmd, env) -> dict:
    """Wall and CPU seconds (user + system of the child) of one command."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    r = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode:
        raise SystemExit(f"{' '.join(map(str, cmd))} failed:\n{r.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall_s": round(wall, 2), "cpu_s": round(cpu, 2), "stderr": r.stderr.strip()[-300:]}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "install.json"))
    ap.add_argument("--no-precompile", action="store_true")
    a = ap.parse_args()
    if not BCTS.exists():
        raise SystemExit(f"{BCTS}: not found (../shared/data)")
    # setuptools' build tree is kept between builds (and its compiled kernels with it)
    shutil.rmtree(ROOT / "build", ignore_errors=True)
    with tempfile.TemporaryDirectory(prefix="lidartrees-install-") as d:
        d = Path(d)
        env = {k: v for k, v in os.environ.items()
               if k not in ("NUMBA_CACHE_DIR", "PYTHONPATH", "VIRTUAL_ENV")}
        if a.no_precompile:
            env["LIDARTREES_NO_PRECOMPILE"] = "1"
        subprocess.run([sys.executable, "-m", "venv", str(d / "venv")], check=True)
        t = time.perf_counter()
        # no pip cache of the wheel: pip builds this checkout's wheel as a new user's would
        r = subprocess.run([str(d / "venv" / "bin" / "pip"), "install", "-q", "--no-cache-dir",
                            str(ROOT)], env=env, capture_output=True, text=True)
        if r.returncode:
            raise SystemExit(f"pip install failed:\n{r.stderr[-3000:]}")
        install_s = round(time.perf_counter() - t, 1)
        exe = str(d / "venv" / "bin" / "lidartrees")
        run_env = {**env, **THREADS}
        version = [timed(ONE + [exe, "--version"], run_env) for _ in range(3)]
        runs = [timed(ONE + [exe, "trees", str(BCTS), str(d / f"t{i}.gpkg"), "-q"], run_env)
                for i in range(3)]
    warm = min(r["wall_s"] for r in runs[1:])
    out = {"what": "trees bcts_1.laz (532 k points), one core, after pip install (no extras, "
                   "no --compile)", "precompiled_wheel": not a.no_precompile,
           "install_s": install_s, "runs": runs, "first_over_warm": round(runs[0]["wall_s"] / warm, 2),
           "version_cpu_s": min(v["cpu_s"] for v in version)}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    old = json.loads(Path(a.out).read_text()) if Path(a.out).exists() else {}
    old["no_precompile" if a.no_precompile else "precompiled"] = out
    Path(a.out).write_text(json.dumps(old, indent=1) + "\n")
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()

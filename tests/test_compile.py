"""Issue 25: ``lidartrees --compile`` compiles and caches the numba kernels once after an
install, so the first command runs from the cache."""
import os
import subprocess
import sys

import pytest

from lidartrees_gis import _accel


@pytest.mark.skipif(not _accel.HAVE_NUMBA, reason="numba not in use")
def test_compile_caches_every_kernel_family(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    r = subprocess.run([sys.executable, "-m", "lidartrees_gis.cli", "--compile"], env=env,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    lines = dict(ln.split(": ", 1) for ln in r.stdout.splitlines() if ": " in ln)
    assert lines["numba"] == "True" and lines["cached"] == "True"
    names = {p.name.split(".")[0] for p in (tmp_path / "cache").rglob("*.nbi")}
    # the kernels of the grids/TINs, of the crowns and of the ground filter
    assert {"_accel", "crowns", "_kernels"} <= names
    # a second process finds them: nothing is compiled again (no new index file)
    before = {p: p.stat().st_mtime_ns for p in (tmp_path / "cache").rglob("*.nbi")}
    r = subprocess.run([sys.executable, "-m", "lidartrees_gis.cli", "--compile"], env=env,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0
    after = {p: p.stat().st_mtime_ns for p in (tmp_path / "cache").rglob("*.nbi")}
    assert after == before

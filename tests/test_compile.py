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


def _kernel_lines():
    from lidartrees_gis.warmup import KERNEL_LIST

    return {ln for ln in KERNEL_LIST.read_text().splitlines() if ln and not ln.startswith("#")}


@pytest.mark.skipif(not _accel.HAVE_NUMBA, reason="numba not in use")
def test_kernel_list_holds_every_kernel_the_commands_compile():
    """The wheel's build compiles kernels.txt's signatures: it must hold every kernel and
    argument type the commands (every crown method) compile, or the first run compiles again."""
    # in a process of its own: this one has compiled whatever the other tests passed
    code = ("from lidartrees_gis.warmup import compile_kernels, kernel_signatures\n"
            "compile_kernels(every_method=True)\nprint('\\n'.join(kernel_signatures()))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    used = set(r.stdout.strip().splitlines())
    assert len(used) >= 17  # grids, TINs, crowns (rg, treex, watershed), outlines, ground
    assert used <= _kernel_lines(), sorted(used - _kernel_lines())


@pytest.mark.skipif(not _accel.HAVE_NUMBA, reason="numba not in use")
def test_build_step_ships_compiled_kernels_that_load_after_a_move(tmp_path):
    """_build.precompile (setuptools' build_py in pyproject.toml) fills the build tree's
    __pycache__; moved elsewhere (pip installs the wheel into site-packages), a new process
    loads every kernel from there and compiles none."""
    import importlib.util
    import shutil
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    spec = importlib.util.spec_from_file_location("_build", root / "_build.py")
    build = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(build)
    lib = tmp_path / "build" / "lib"
    shutil.copytree(root / "lidartrees_gis", lib / "lidartrees_gis", symlinks=True,
                    ignore=shutil.ignore_patterns("__pycache__"))
    msg = build.precompile(str(lib))
    assert msg == f"{len(_kernel_lines())} kernel signatures compiled", msg
    site = tmp_path / "site"
    shutil.move(str(lib), str(site))
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(PYTHONPATH=str(site), NUMBA_DEBUG_CACHE="1", PYTHONDONTWRITEBYTECODE="1")
    r = subprocess.run([sys.executable, "-m", "lidartrees_gis.warmup", "--build"], env=env,
                       cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    loaded = r.stdout.count("[cache] data loaded from")
    assert loaded >= len(_kernel_lines()) and "data saved" not in r.stdout, r.stdout[-2000:]
    assert str(site) in r.stdout


def test_the_build_step_is_in_the_source_distribution():
    """pyproject.toml names _build.BuildPy as setuptools' build_py: an sdist without _build.py
    could not be built into a wheel (MANIFEST.in includes it)."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    assert 'build_py = "_build.BuildPy"' in (root / "pyproject.toml").read_text()
    assert "include _build.py" in (root / "MANIFEST.in").read_text().splitlines()
    assert (root / "_build.py").exists()

"""setuptools build step: the wheel carries the numba kernels compiled (issue 25).

After the sources are copied into the build tree, ``python -m lidartrees_gis.warmup --build``
runs there and compiles every kernel listed in ``lidartrees_gis/kernels.txt`` into the build
tree's ``__pycache__`` folders (numba's on-disk cache, keyed by the source's content, the numba
version and the CPU): a wheel built on the machine it is installed on (``pip install
/path/to/lidartrees_gis``) then runs its first command as fast as the later ones. Where that
cannot be done (numba missing, another CPU, another numba at run time) the kernels compile on
the first run, as before; a failure here never fails the build.
"""
from __future__ import annotations

import os
import subprocess
import sys

from setuptools.command.build_py import build_py


def precompile(build_lib: str) -> str:
    """Compile the listed kernels into ``build_lib``'s ``__pycache__`` folders, in a process of
    their own; returns its last line of output (never raises)."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    # the build tree first; pip's isolated build environment reaches numba through the
    # PYTHONPATH it set (its own site folder), kept after it
    path = [os.path.abspath(build_lib)] + [p for p in [env.get("PYTHONPATH")] if p]
    env.update(PYTHONPATH=os.pathsep.join(path), PYTHONDONTWRITEBYTECODE="1")
    try:
        r = subprocess.run([sys.executable, "-m", "lidartrees_gis.warmup", "--build"],
                           env=env, cwd=build_lib, capture_output=True, text=True, timeout=900)
    except (OSError, subprocess.SubprocessError) as e:
        return f"kernels not precompiled ({e}); they compile on the first run"
    msg = (r.stdout or r.stderr).strip().splitlines()
    return msg[-1] if msg else f"exit {r.returncode}"


class BuildPy(build_py):
    def run(self):
        super().run()
        if getattr(self, "editable_mode", False) or os.environ.get("LIDARTREES_NO_PRECOMPILE"):
            return  # an editable install runs from the sources (`lidartrees --compile`)
        print("lidartrees_gis: " + precompile(self.build_lib))

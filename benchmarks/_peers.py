"""The R peers of the benchmarks (lasR 0.21.1, lidR 4.1.2, built by ../shared/peers/build.sh
into ~/.cache/lidartrees-peers/rlib): how Rscript finds them."""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

#: where ../shared/peers/build.sh installs the R packages by default
PEERS_RLIB = Path.home() / ".cache" / "lidartrees-peers" / "rlib"


def r_env() -> dict:
    """Environment for Rscript: the peers' library when R_LIBS is not set."""
    env = dict(os.environ)
    if "R_LIBS" not in env and PEERS_RLIB.is_dir():
        env["R_LIBS"] = str(PEERS_RLIB)
    return env


def has_r_package(pkg: str) -> bool:
    """Whether Rscript is on the PATH and loads ``pkg``."""
    rs = shutil.which("Rscript")
    return bool(rs) and subprocess.run(
        [rs, "-e", f"quit(status = if (requireNamespace('{pkg}', quietly = TRUE)) 0 else 1)"],
        capture_output=True, env=r_env()).returncode == 0

"""Finding the ``lidartrees`` command that the algorithms run.

The algorithms run the ``lidartrees`` CLI in a subprocess, from the Python environment where
lidartrees_gis and its dependencies are installed (see docs/QGIS.md). The QGIS
process itself only reads the parameter table (``lidartrees_gis.cli.commands``, standard library
only; the plugin zip carries a copy), so numpy, GDAL and GEOS builds never meet QGIS's own.

Where the command is looked up, first found wins:
1. the environment variable ``LIDARTREES_EXE``;
2. the QGIS setting ``lidartrees/executable`` (Settings > Options > Advanced);
3. ``lidartrees`` on the PATH, then ``~/.local/bin/lidartrees`` and ``~/.venvs/lidartrees/bin/lidartrees``.
"""
import importlib
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SETTING = "lidartrees/executable"


def _ensure_path():
    try:
        importlib.import_module("lidartrees_gis.cli.commands")
    except ImportError:
        if os.path.isdir(os.path.join(HERE, "lidartrees_gis")) and HERE not in sys.path:
            sys.path.insert(0, HERE)


def commands():
    """The shared command table (lidartrees_gis.cli.commands.COMMANDS)."""
    _ensure_path()
    return importlib.import_module("lidartrees_gis.cli.commands").COMMANDS


def find_executable():
    """Path of the ``lidartrees`` command, or None."""
    cands = [os.environ.get("LIDARTREES_EXE")]
    try:
        from qgis.core import QgsSettings

        cands.append(QgsSettings().value(SETTING, "", type=str))
    except Exception:  # noqa: BLE001 - outside QGIS
        pass
    cands += [shutil.which("lidartrees"), os.path.expanduser("~/.local/bin/lidartrees"),
              os.path.expanduser("~/.venvs/lidartrees/bin/lidartrees")]
    for c in cands:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return c
    return None


_CHECKED = {}


def executable_error():
    """None when a working ``lidartrees`` command is found, else what to do."""
    from .texts import tr

    exe = find_executable()
    if exe is None:
        return tr("LiDAR Trees: the 'lidartrees' command was not found. Install the lidartrees_gis "
                  "package from its source folder (the one holding pyproject.toml) or its wheel "
                  "(lidartrees_gis-*.whl) in its own environment (python3 -m venv "
                  "~/.venvs/lidartrees && ~/.venvs/lidartrees/bin/pip install "
                  "/path/to/lidartrees_gis; it is not published on PyPI) and, if it is not on "
                  "the PATH, set the environment variable LIDARTREES_EXE or the QGIS setting "
                  "'{setting}' to its path.").format(
                      setting=SETTING)
    if exe not in _CHECKED:
        try:
            r = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=60)
            _CHECKED[exe] = None if r.returncode == 0 else (
                "LiDAR Trees: '{exe} --version' failed: {error}",
                dict(exe=exe, error=(r.stderr or r.stdout).strip()[-500:]))
        except (OSError, subprocess.SubprocessError) as exc:
            _CHECKED[exe] = ("LiDAR Trees: cannot run {exe}: {error}", dict(exe=exe, error=exc))
    found = _CHECKED[exe]
    return None if found is None else tr(found[0]).format(**found[1])


def styles_dir():
    """The folder holding the .qml styles (inside the plugin, or the repository's styles/)."""
    for cand in (os.path.join(HERE, "styles"), os.path.join(os.path.dirname(HERE), "styles")):
        if os.path.isdir(cand):
            return cand
    return None

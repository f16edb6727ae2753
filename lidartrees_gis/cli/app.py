"""``lidartrees`` command line, GDAL/OGR style (``-tr``, ``-a_srs``, ``-t_srs``, ``-co``,
``-overwrite``, ``-q``). Options are built from :mod:`lidartrees_gis.cli.commands`.

Exit codes: 0 success, 1 error (one-line message on stderr), 2 usage error, 130 cancelled.
"""
from __future__ import annotations

import argparse
import json
import math
import re
import sys

from .._version import __version__
from .commands import COMMANDS
from ..errors import Cancelled, LidarTreesError
from ..progress import LineProgress, NullProgress, TqdmProgress


def _help(p):
    text = p.help + (f" [{p.unit}]" if p.unit else "")
    if p.default not in (None, False, "") and not p.positional:
        text += f" (default: {p.default})"
    return text.replace("%", "%%")


def _add_param(sp, p):
    if p.positional:
        if p.required or p.kind not in ("outdir",):
            sp.add_argument(p.name, help=p.help)
        else:
            sp.add_argument(p.name, nargs="?", default=p.default, help=p.help)
        return
    flags = [p.flag, *p.aliases]
    if p.kind == "bool":
        sp.add_argument(*flags, dest=p.name, action="store_true", default=p.default, help=_help(p))
    elif p.kind == "kv":
        sp.add_argument(*flags, dest=p.name, action="append", metavar="KEY=VALUE", help=_help(p))
    elif p.kind == "choice":
        sp.add_argument(*flags, dest=p.name, choices=p.choices, default=p.default, help=_help(p))
    else:
        sp.add_argument(*flags, dest=p.name, default=p.default, required=p.required,
                        metavar=p.name.upper(), help=_help(p),
                        type=_decimal_comma if p.kind in ("float", "res", "int") else None)


_COMMA_NUMBER = re.compile(r"\s*[+-]?\d*,\d+\s*")


def _decimal_comma(text: str) -> str:
    """A number given with a decimal comma (``-tr 0,5``, as a pt-BR user writes it) read with
    a point; any other text as it is (the option's own check names what is wrong)."""
    return text.replace(",", ".") if _COMMA_NUMBER.fullmatch(str(text)) else text


def build_parser() -> argparse.ArgumentParser:
    """The ``lidartrees`` argument parser."""
    ap = argparse.ArgumentParser(prog="lidartrees", allow_abbrev=False,
                                 description="LiDAR point clouds of planted forests to canopy height "
                                             "rasters, tree tops and crowns.")
    ap.add_argument("--version", action="version", version=f"lidartrees_gis {__version__}")
    ap.add_argument("--compile", action="store_true",
                    help="Compile and cache the numba kernels once, after installing (about "
                         "30 s), so the first command runs as fast as the later ones")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND")
    for cmd in COMMANDS.values():
        sp = sub.add_parser(cmd.name, help=cmd.summary.replace("%", "%%"),
                            description=cmd.summary + ". " + cmd.help,
                            allow_abbrev=False)
        for p in cmd.params:
            _add_param(sp, p)
        sp.add_argument("-q", "--quiet", action="store_true",
                        help="No progress bar (the summary, warnings and errors are still "
                        "printed)")
        # for programs driving the CLI (the QGIS provider): progress lines and a result file
        sp.add_argument("--progress-lines", action="store_true", help=argparse.SUPPRESS)
        sp.add_argument("--result-json", metavar="FILE", help=argparse.SUPPRESS)
    return ap


def _places(key: str, v: float) -> float:
    """``v`` rounded to what the figure ``key`` means: heights, diameters, distances and
    biases to the cm, per-hectare figures to 0.1, percentages to 0.01, azimuths to 0.1°,
    shares and scores to 0.0001; others to 4 decimals (0.1 mm of a coordinate), or 4
    significant digits below 1."""
    k = str(key).lower()
    if k.endswith("per_ha"):
        return round(v, 1)
    if "azimuth" in k:  # an axis in [0, 180): 179.96 reads 0.0, not 180.0
        return round(v % 180.0 + 1e-9, 1) % 180.0
    if k.endswith("pct"):
        return round(v, 2)
    if any(w in k for w in ("height", "bias", "rmse", "diameter", "distance", "dist")):
        return round(v, 2)
    if k in ("recall", "precision", "f_score") or k.endswith("share"):
        return round(v, 4)
    if v == 0 or abs(v) >= 1:
        return round(v, 4)
    return float(f"{v:.4g}")


def _tidy(v, key: str = ""):
    """Numbers as a reader wants them, each rounded to what it means (:func:`_places`), so
    neither binary artefacts (358.28000000000003) nor ten decimals (0.06278667418) reach the
    page, and coordinates keep their millimetres."""
    if isinstance(v, float):
        return _places(key, v) + 0.0 if math.isfinite(v) else v
    if isinstance(v, dict):
        return {k: _tidy(x, k) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return type(v)(_tidy(x, key) for x in v)
    return v


def result_lines(res: dict, prefix: str = "", sep: str = ", ") -> list:
    """A command's result as plain ``key: value`` lines: nested dicts as ``key.sub: value``,
    lists of values joined by ``sep``, lists of dicts as ``key.1.sub: value``; None left
    out."""
    out = []
    for k, v in res.items():
        key = f"{prefix}{k}"
        if v is None or k == "table":
            continue
        if isinstance(v, dict):
            out += result_lines(v, key + ".", sep)
        elif isinstance(v, (list, tuple)) and v and all(isinstance(x, dict) for x in v):
            for i, x in enumerate(v, 1):
                out += result_lines(x, f"{key}.{i}.", sep)
        elif isinstance(v, (list, tuple)):
            out.append(f"{key}: {sep.join(str(x) for x in v)}")
        else:
            out.append(f"{key}: {v}")
    return out


def _for_reader(text: str) -> str:
    """A printed line in the locale's numbers: decimal commas in pt_BR (as the tables write
    them, :mod:`lidartrees_gis.io.tables`), else as it is."""
    from ..io.tables import decimal_commas, is_ptbr

    return decimal_commas(text) if is_ptbr() else text


def _print_result(name, res, as_json):
    """The result on stdout (the progress and the messages go to stderr): ``key: value`` lines,
    or JSON with ``--json``; printed with ``-q`` too."""
    if as_json:
        print(json.dumps(res, indent=2, default=str))
        return
    if not isinstance(res, dict):
        return
    from ..io.tables import is_ptbr

    res = {k: (v if k == "table" else _tidy(v, k)) for k, v in res.items()}
    if name == "info":
        res = {k: v for k, v in res.items() if k != "crs_wkt"}
    # pt_BR: decimal commas, so a list's values are parted by semicolons
    for line in result_lines(res, sep="; " if is_ptbr() else ", "):
        print(_for_reader(line))
    if "table" in res:
        print(_for_reader(str(res["table"])))


def _join_dash_values(argv, ap):
    """GDAL-style ``-g -4:1:0.5``: an option value that starts with '-' is glued to its flag
    (``-g=-4:1:0.5``) so argparse does not take it for an option."""
    flags = set()
    for action in ap._subparsers._group_actions[0].choices.values() if ap._subparsers else ():
        for a in action._actions:
            if a.option_strings and a.nargs is None and a.const is None:
                flags.update(a.option_strings)
    known = {s for sp in ap._subparsers._group_actions[0].choices.values()
             for a in sp._actions for s in a.option_strings}
    out, i = [], 0
    while i < len(argv):
        tok = argv[i]
        if tok in flags and i + 1 < len(argv) and argv[i + 1].startswith("-") \
                and argv[i + 1] not in known:
            out.append(f"{tok}={argv[i + 1]}")
            i += 2
            continue
        out.append(tok)
        i += 1
    return out


def check_numbers(cmd, kw) -> None:
    """Every number option of ``cmd`` in ``kw`` checked before the run, in one place: finite,
    and within :data:`~lidartrees_gis.bounds.NUMBER_BOUNDS` for its unit; a one-line error
    naming the option."""
    from ..bounds import NUMBER_OR_WORD, check_number

    for p in cmd.params:
        # (-tr is checked by grid.check_resolution, for the API too)
        unit = NUMBER_OR_WORD.get(p.name) if p.kind == "str" else (
            p.unit if p.kind in ("float", "int") else None)
        v = kw.get(p.name)
        if unit is None or v is None or isinstance(v, bool) or str(v).strip() == "":
            continue
        check_number(p.flag, v, unit, p.name, text_ok=p.kind == "str")


def main(argv=None) -> int:
    """Run the CLI; returns the exit code."""
    ap = build_parser()
    args = ap.parse_args(_join_dash_values(list(sys.argv[1:] if argv is None else argv), ap))
    if args.compile and not args.command:
        from ..warmup import compile_kernels

        print("lidartrees: compiling the numba kernels (once)", file=sys.stderr)
        print("\n".join(result_lines(compile_kernels())))
        return 0
    if not args.command:
        ap.print_help(sys.stderr)
        return 2
    cmd = COMMANDS[args.command]
    import logging

    logging.getLogger("laspy").setLevel(logging.CRITICAL)  # read errors are reported as ours
    kw = {p.name: getattr(args, p.name) for p in cmd.params}
    as_json = bool(kw.pop("json", False))
    if args.progress_lines:
        progress = LineProgress()
    elif args.quiet or not sys.stderr.isatty():  # no bar frames in logs and pipes
        progress = NullProgress()
    else:
        progress = TqdmProgress(desc=cmd.name)
    _terminate_as_interrupt()
    import warnings

    from ..errors import DataWarning

    def _show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, DataWarning):
            text = f"lidartrees {cmd.name}: warning: {message}"
            print(text if args.progress_lines else _for_reader(text), file=sys.stderr)

    warnings.showwarning = _show
    warnings.simplefilter("default", DataWarning)
    if cmd.name not in ("info", "evaluate") and not args.quiet and sys.stderr.isatty():
        _first_run_note()  # for someone waiting at a terminal
    try:
        check_numbers(cmd, kw)
        if kw.get("creation_options"):
            from ..io.raster import check_creation_options

            check_creation_options(kw["creation_options"])
        res = cmd.run(**kw, progress=progress)
    except Cancelled:
        print("lidartrees: cancelled", file=sys.stderr)
        return 130
    except KeyboardInterrupt:
        print("lidartrees: interrupted; no output written", file=sys.stderr)
        return 130
    except (LidarTreesError, OSError, MemoryError) as exc:
        if hasattr(progress, "close"):
            progress.close()
        if getattr(exc, "result", None) and not args.progress_lines:  # written without some tiles
            _print_result(cmd.name, exc.result, as_json)
        text = f"lidartrees {cmd.name}: error: {_error_text(exc)}"
        print(text if args.progress_lines else _for_reader(text), file=sys.stderr)
        return 1
    finally:
        if hasattr(progress, "close"):
            progress.close()
    if args.result_json:
        with open(args.result_json, "w", encoding="utf-8") as fh:
            json.dump(res, fh, default=str)
    if not args.progress_lines:  # QGIS reads --result-json
        _print_result(cmd.name, res, as_json)
    return 0


def _first_run_note() -> None:
    """One line on stderr on the first run after an install: numba compiles the kernels then
    (tens of seconds, once) and caches them for every later run."""
    from .. import _accel

    if _accel.HAVE_NUMBA and not _accel.kernels_cached():
        print("lidartrees: first run after installing: compiling the numba kernels once (10-40 "
              "s; cached for every later run; `lidartrees --compile` does it ahead)",
              file=sys.stderr)


def _error_text(exc) -> str:
    """One line for an error: ours as written; the system's (no space, no permission, name too
    long) with the file; out of memory with what to do."""
    if isinstance(exc, LidarTreesError):
        return str(exc)
    if isinstance(exc, MemoryError):
        return "out of memory; process the area in tiles (-tile_size) or use a larger cell size (-tr)"
    where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
    if len(where) > 160:
        where = where[:80] + "..." + where[-60:]
    return f"{where}{exc.strerror or exc}"


def _terminate_as_interrupt():
    """SIGTERM (a cancel from QGIS) unwinds like Ctrl-C, so temporary outputs are removed."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return

    def handler(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, handler)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

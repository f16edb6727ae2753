"""Fuzzing the readers and the CLI with malformed inputs (issue 11).

``python -m lidartrees_gis.fuzz --cases 2000 --seed 0 --dir /tmp/fuzz`` builds the cases (a seeded
mix of mutated XYZ text, LAS/LAZ with broken headers or records, compressed and non-point files
and odd parameter values), runs each through ``lidartrees_gis.cli.app.main`` in a worker process (one
process for many cases, restarted when a case kills it or runs over the time limit) and reports,
per case, the exit code, the time, the last stderr line and whether the stderr held a traceback.

A case passes when it exits 0, or exits 1 with a single ``lidartrees CMD: error: ...`` line
(after any one-line warnings), in less than the time limit, without a traceback or a signal.
"""
from __future__ import annotations

import argparse
import io
import json
import struct
import sys
import time
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np

TIME_LIMIT = 20.0


# ---------------------------------------------------------------------------------------------
# seed inputs
def _base_points(rng, n=300):
    x = 500000.0 + rng.random(n) * 30
    y = 7500000.0 + rng.random(n) * 30
    z = 600.0 + rng.random(n) * 20
    return x, y, z


def _write_las(path, x, y, z, cls=None, compressed=False):
    import laspy
    import pyproj

    h = laspy.LasHeader(point_format=6, version="1.4")
    h.scales = np.array([0.01, 0.01, 0.01])
    h.offsets = np.array([np.floor(x.min()), np.floor(y.min()), np.floor(z.min())])
    h.add_crs(pyproj.CRS.from_epsg(31983))
    las = laspy.LasData(h)
    las.x, las.y, las.z = x, y, z
    las.classification = np.ones(x.size, np.uint8) if cls is None else cls
    las.write(str(path))


def _xyz_text(x, y, z, delim="\t", comma=False):
    lines = ["X\tY\tZ".replace("\t", delim)]
    for a, b, c in zip(x, y, z):
        s = delim.join(f"{v:.2f}" for v in (a, b, c))
        lines.append(s.replace(".", ",") if comma else s)
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------
# mutations
_TOKENS = ["nan", "inf", "-inf", "1e400", "1e300", "-1e300", "5e-324", "0x10", "1_000", "١٢٣",
           "--1", "1..2", "", " ", "\x00", "\ufeff", "é", "1,2,3", "999999999999999999999",
           "7500000.0", "75000000.0", "NULL", "-", "+"]


def _mutate_text(rng, text):
    lines = text.split("\n")
    kind = int(rng.integers(0, 13))
    if kind == 12:  # pt-BR numbers: '.' between thousands and a decimal comma (412.955,63)
        def br(v):
            whole, frac = f"{float(v):.2f}".split(".")
            return f"{int(whole):,}".replace(",", ".") + "," + frac
        out = [lines[0]]
        for ln in lines[1:]:
            parts = ln.split("\t")
            try:
                out.append("\t".join(br(p_) for p_ in parts))
            except ValueError:
                out.append(ln)
        return "\n".join(out), kind
    if kind == 0:  # random bytes in the middle
        i = int(rng.integers(0, len(text)))
        return (text[:i] + "".join(chr(int(c)) for c in rng.integers(0, 0x3000, 20)) + text[i:]), kind
    if kind == 1:  # truncate
        return text[: int(rng.integers(0, len(text)))], kind
    if kind == 2:  # a token in place of a number
        r = int(rng.integers(1, len(lines) - 1))
        parts = lines[r].split("\t")
        parts[int(rng.integers(0, len(parts)))] = str(rng.choice(_TOKENS))
        lines[r] = "\t".join(parts)
        return "\n".join(lines), kind
    if kind == 3:  # one wrong digit: a coordinate 10x away
        r = int(rng.integers(1, len(lines) - 1))
        parts = lines[r].split("\t")
        parts[int(rng.integers(0, 2))] = "5" + parts[0]
        lines[r] = "\t".join(parts)
        return "\n".join(lines), kind
    if kind == 4:  # missing or extra columns
        r = int(rng.integers(1, len(lines) - 1))
        lines[r] = lines[r] + "\t1\t2" if rng.random() < 0.5 else lines[r].split("\t")[0]
        return "\n".join(lines), kind
    if kind == 5:  # empty / header only / blank
        return str(rng.choice(["", "\n", "X\tY\tZ\n", "\n\n\n", "\ufeff"])), kind
    if kind == 6:  # delimiters mixed
        return text.replace("\t", str(rng.choice([",", ";", " ", "  ", "|"])), int(rng.integers(1, 50))), kind
    if kind == 7:  # decimal commas with comma delimiter
        return text.replace(".", ",").replace("\t", ","), kind
    if kind == 8:  # a very long line
        return text + "1" * int(rng.integers(10_000, 200_000)) + "\n", kind
    if kind == 9:  # CR line ends, NULs
        return text.replace("\n", str(rng.choice(["\r", "\r\n", "\x00\n"]))), kind
    if kind == 10:  # all points on one spot or one line
        return "X\tY\tZ\n" + "500000\t7500000\t600\n" * int(rng.integers(1, 50)), kind
    return "X\tY\tZ\n" + "\n".join(f"{a}\t{b}\t{c}" for a, b, c in rng.choice(_TOKENS, (5, 3))), kind


def _mutate_las(rng, data: bytes):
    b = bytearray(data)
    kind = int(rng.integers(0, 11))
    if kind == 9 and b[104] & 0x80 and len(b) > 400:  # LAZ: the chunk table the decoder trusts
        off, = struct.unpack_from("<I", b, 96)
        ct, = struct.unpack_from("<q", b, off)
        which = int(rng.integers(0, 4))
        if which == 0:  # where it is
            struct.pack_into("<q", b, off, int(rng.integers(-2, 2 ** 40)))
        elif 0 < ct < len(b) - 8:
            if which == 1:  # its version and chunk count
                struct.pack_into("<II", b, ct, int(rng.choice([0, 1, 2 ** 32 - 1])),
                                 int(rng.choice([0, 1, 2, 10 ** 6, 2 ** 32 - 1])))
            elif which == 2:  # its entries
                b[ct + 8:] = bytes(rng.integers(0, 256, len(b) - ct - 8, dtype=np.uint8))
            else:  # overwritten
                b[ct:ct + 64] = b"\xff" * min(64, len(b) - ct)
        return bytes(b), kind
    if kind == 10:  # header fields one by one: offset to points doubled, record length, VLRs
        field = int(rng.integers(0, 3))
        if field == 0:
            off, = struct.unpack_from("<I", b, 96)
            struct.pack_into("<I", b, 96, min(2 * off, 2 ** 32 - 1))
        elif field == 1:
            rl, = struct.unpack_from("<H", b, 105)
            struct.pack_into("<H", b, 105, int(rl + rng.choice([-4, -1, 1, 4])) & 0xFFFF)
        else:
            struct.pack_into("<I", b, 100, int(rng.choice([0, 1, 5, 2 ** 20])))
        return bytes(b), kind
    if kind == 0:  # truncate
        return bytes(b[: int(rng.integers(0, len(b)))]), kind
    if kind == 1:  # random bytes anywhere
        for _ in range(int(rng.integers(1, 20))):
            b[int(rng.integers(0, len(b)))] = int(rng.integers(0, 256))
        return bytes(b), kind
    if kind == 2:  # header bytes (first 375)
        for _ in range(int(rng.integers(1, 6))):
            b[int(rng.integers(0, min(375, len(b))))] = int(rng.integers(0, 256))
        return bytes(b), kind
    if kind in (3, 4):  # scale (131) / offset (155) doubles
        off = 131 if kind == 3 else 155
        k = int(rng.integers(0, 3))
        val = float(rng.choice([1e300, -1e300, 0.0, 1e-300, np.nan, np.inf, 1e6, -0.01]))
        struct.pack_into("<d", b, off + 8 * k, val)
        return bytes(b), kind
    if kind == 5:  # point counts (legacy 107, 1.4: 247)
        v = int(rng.choice([0, 1, 2 ** 31, 2 ** 32 - 1, 10 ** 9]))
        struct.pack_into("<I", b, 107, v & 0xFFFFFFFF)
        if rng.random() < 0.5:
            struct.pack_into("<Q", b, 247, v)
        return bytes(b), kind
    if kind == 6:  # bounds (179: max x, min x, max y, min y, max z, min z)
        k = int(rng.integers(0, 6))
        struct.pack_into("<d", b, 179 + 8 * k, float(rng.choice([0.0, 1e300, -1e300, np.nan])))
        return bytes(b), kind
    if kind == 7:  # point data offset / record length / format
        field = int(rng.integers(0, 3))
        if field == 0:
            struct.pack_into("<I", b, 96, int(rng.integers(0, 2 ** 32)))
        elif field == 1:
            struct.pack_into("<H", b, 105, int(rng.integers(0, 2 ** 16)))
        else:
            b[104] = int(rng.integers(0, 256))
        return bytes(b), kind
    return bytes(rng.integers(0, 256, int(rng.integers(0, 5000)), dtype=np.uint8)), kind


_COMMANDS = [
    (["info"], 6), (["grid", "{out}.tif", "-tr", "1"], 4), (["chm", "{out}.tif", "-tr", "1"], 2),
    (["trees", "{out}.gpkg", "-tr", "1"], 1), (["ground", "{out}.laz"], 1),
]
_BAD_ARGS = [["-tr", "0"], ["-tr", "-1"], ["-tr", "5e-324"], ["-tr", "nan"], ["-tr", "0.001"],
             ["-tr", "1e9"], ["-a_srs", "EPSG:999999"], ["-a_srs", "garbage"],
             ["-t_srs", "EPSG:4326"], ["-s_srs", "EPSG:29193"], ["-co", "COMPRESS=NOPE"],
             ["-co", "=="], ["--columns", "x,y"], ["--columns", "z,z,z"], ["--delimiter", ";"], ["--delimiter", "abc"],
             ["-tile_size", "0.5"], ["-tile_size", "1e-3"], ["-tile_size", "1e9"]]


def _flags(command):
    from .cli.commands import COMMANDS

    out = set()
    for p in COMMANDS[command].params:
        if p.flag:
            out.add(p.flag)
            out.update(p.aliases)
    return out


def make_cases(n, seed, workdir):
    """``n`` cases: (id, argv) with their input files written under ``workdir``."""
    rng = np.random.default_rng(seed)
    work = Path(workdir)
    work.mkdir(parents=True, exist_ok=True)
    x, y, z = _base_points(rng)
    base_las = work / "base.las"
    _write_las(base_las, x, y, z)
    base_laz = work / "base.laz"
    _write_las(base_laz, x, y, z)
    las_bytes, laz_bytes = base_las.read_bytes(), base_laz.read_bytes()
    text = _xyz_text(x, y, z)
    names, weights = zip(*_COMMANDS)
    p = np.array(weights, float) / sum(weights)
    cases = []
    for i in range(n):
        kind = int(rng.integers(0, 10))
        if kind <= 4:
            data, sub = _mutate_text(rng, text)
            f = work / f"c{i}.xyz"
            f.write_bytes(data.encode("utf-8", "surrogatepass") if rng.random() < 0.9
                          else data.encode("latin-1", "replace"))
            label = f"xyz/{sub}"
        elif kind <= 6:
            data, sub = _mutate_las(rng, las_bytes)
            f = work / f"c{i}.las"
            f.write_bytes(data)
            label = f"las/{sub}"
        elif kind == 7:
            data, sub = _mutate_las(rng, laz_bytes)
            f = work / f"c{i}.laz"
            f.write_bytes(data)
            label = f"laz/{sub}"
        elif kind == 8:  # compressed or not point data
            import gzip

            choice = int(rng.integers(0, 4))
            if choice == 0:
                raw = gzip.compress(text.encode())
                f = work / f"c{i}.xyz.gz"
                f.write_bytes(raw[: int(rng.integers(10, len(raw)))])
            elif choice == 1:
                f = work / f"c{i}.xyz"
                f.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(rng.integers(0, 256, 500, dtype=np.uint8)))
            elif choice == 2:
                f = work / f"c{i}.xyz"
                f.write_bytes(b"SQLite format 3\x00" + bytes(200))
            else:
                f = work / f"c{i}.txt"
                f.write_text("Lorem ipsum dolor sit amet\nconsectetur 12 adipiscing\n" * 20)
            label = f"other/{choice}"
        else:  # a valid file with odd parameters
            f = base_las if rng.random() < 0.5 else work / "base.xyz"
            if not f.exists():
                f.write_text(text)
            label = "args"
        cmd = list(names[int(rng.choice(len(names), p=p))])
        argv = [cmd[0], str(f)] + [a.format(out=str(work / f"o{i}")) for a in cmd[1:]] + ["-q"]
        flags = _flags(cmd[0])
        allowed = [a for a in _BAD_ARGS if a[0] in flags]
        if allowed and (label == "args" or rng.random() < 0.1):
            extra = list(allowed[int(rng.integers(0, len(allowed)))])
            if "-tr" in extra and "-tr" in argv:
                j = argv.index("-tr")
                del argv[j:j + 2]
            argv += extra
        cases.append({"id": i, "label": label, "argv": argv})
    return cases


# ---------------------------------------------------------------------------------------------
# running
def _worker(conn):
    """Run cases sent over ``conn`` one by one (imports once)."""
    from .cli.app import main

    while True:
        case = conn.recv()
        if case is None:
            return
        err, out = io.StringIO(), io.StringIO()
        t = time.perf_counter()
        try:
            with redirect_stderr(err), redirect_stdout(out):
                code = main(case["argv"])
        except SystemExit as e:  # argparse usage errors
            code = e.code if isinstance(e.code, int) else 1
        except BaseException:  # noqa: BLE001 - a traceback is what we are looking for
            import traceback

            err.write(traceback.format_exc())
            code = -999
        import resource

        conn.send({"code": code, "seconds": time.perf_counter() - t,
                   "stderr": err.getvalue()[-4000:], "stdout": out.getvalue()[-4000:],
                   # the worker's peak so far (KB on Linux): a case that grew it shows here
                   "maxrss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024})


def run_cases(cases, time_limit=TIME_LIMIT, progress=None):
    """Run ``cases`` in a worker process; returns one result dict per case."""
    import multiprocessing as mp

    ctx = mp.get_context("spawn")
    results = []
    proc = parent = None

    def start():
        a, b = ctx.Pipe()
        p = ctx.Process(target=_worker, args=(b,))
        p.start()
        return p, a

    for k, case in enumerate(cases):
        if proc is None or not proc.is_alive():
            proc, parent = start()
        parent.send(case)
        t = time.perf_counter()
        res = None
        while time.perf_counter() - t < time_limit + 30:  # + start-up of a fresh worker
            if parent.poll(0.05):
                try:
                    res = parent.recv()
                except EOFError:
                    res = None
                break
            if not proc.is_alive():
                break
        if res is None:
            signal = None if proc.is_alive() else -proc.exitcode if proc.exitcode else None
            if proc.is_alive():
                proc.kill()
            proc.join()
            proc = None
            res = {"code": None, "seconds": time.perf_counter() - t, "stderr": "",
                   "signal": signal, "hang": signal is None}
        results.append({**case, **res})
        if progress:
            progress(k + 1, len(cases))
    if proc is not None:
        parent.send(None)
        proc.join(5)
    return results


def verdict(r, time_limit=TIME_LIMIT) -> str | None:
    """Why a case failed, or None when it passed."""
    if r.get("hang"):
        return "hang"
    if r.get("signal"):
        return f"signal {r['signal']}"
    if r["code"] is None:
        return "worker died"
    if r["seconds"] > time_limit:
        return f"slow ({r['seconds']:.1f} s)"
    if "Traceback" in r["stderr"]:
        return "traceback"
    if r["code"] == 0:
        return None
    if r["code"] != 1:
        return f"exit {r['code']}"
    lines = [ln for ln in r["stderr"].splitlines()
             if ln.strip() and not (ln.startswith("lidartrees") and ": warning: " in ln)]
    if len(lines) != 1 or not lines[0].startswith("lidartrees"):
        return "not one error line"
    return None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--dir", default="fuzz_work")
    ap.add_argument("--out", default=None, help="JSON report")
    a = ap.parse_args(argv)
    cases = make_cases(a.cases, a.seed, a.dir)
    t = time.perf_counter()
    res = run_cases(cases, progress=lambda k, n: print(f"\r{k}/{n}", end="", file=sys.stderr))
    print(file=sys.stderr)
    bad = [(r, verdict(r)) for r in res]
    bad = [(r, v) for r, v in bad if v]
    summary = {"cases": len(res), "failed": len(bad), "seconds": round(time.perf_counter() - t, 1)}
    by = {}
    for r, v in bad:
        by.setdefault(v, []).append(r["id"])
    summary["by_reason"] = {k: len(v) for k, v in by.items()}
    print(json.dumps(summary, indent=1))
    for r, v in bad[:40]:
        last = (r["stderr"].strip().splitlines() or [""])[-1][:200]
        print(f"{r['id']} {r['label']} {v}: {' '.join(r['argv'][:2])} ... -> {last}")
    if a.out:
        Path(a.out).write_text(json.dumps({"summary": summary, "failures": [
            {**r, "verdict": v} for r, v in bad]}, indent=1, default=str))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

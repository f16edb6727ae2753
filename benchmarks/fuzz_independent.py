"""An independent fuzzer for the CLI (issue 26): it shares no code with
``lidartrees_gis.fuzz`` (the in-suite fuzzer) and mutates other things in other ways.

Seeds are the shared REAL files (``../shared/data``: LAZ of lidR, NEON and lasR, XYZ text of
TLS scans), cut to a few thousand points with their own headers, VLRs and point formats kept.
Mutations: header fields set to boundary values one by one (offsets, record lengths, counts,
scales, bounds, point format), random bytes over the chunk table, the VLRs or the point records,
truncation at any offset, chunks repeated; XYZ text with decimal commas, thousands separators,
a BOM, NaN/inf/huge tokens, columns dropped, shuffled or added, odd delimiters, CRLF, binary
junk; random commands with option values drawn from each parameter's kind (numbers at their
limits, choices misspelt, paths that do not exist). Each case runs in a forked process calling
``lidartrees_gis.cli.main``; a case fails when the process dies by a signal (abort), runs over
20 s (hang) or an exception escapes ``main`` (traceback).

    python benchmarks/fuzz_independent.py --cases 10000 --seed 7 --jobs 2

writes ``benchmarks/results/fuzz_independent.json`` (counts, failures with their reproducer).
"""
from __future__ import annotations

import argparse
import io
import json
import os
import random
import shutil
import signal
import struct
import sys
import tempfile
import time
import traceback
from pathlib import Path

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # no thread pools in the forking process

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
DATA = Path(os.environ.get("LIDARTREES_DATA", HERE.parents[0] / ".." / "shared" / "data")).resolve()
TIME_LIMIT = 20.0
SEED_LAZ = ["lidR_extdata/MixedConifer.laz", "lidR_extdata/Topography.laz",
            "neon_teak_dev/TEAK_043.laz", "lasR_bcts/bcts_1.laz", "lidR_extdata/dbh.laz"]
SEED_XYZ = ["xyz_text/ITSMe_tree_1_pc.txt", "xyz_text/rTLS_pc_tree.txt", "xyz_text/ITSMe_dtm.txt"]


# ------------------------------------------------------------------------------ seed files
def make_seeds(folder: Path, n_points=4000, seed=0) -> list:
    """Real files cut to ``n_points`` (a window of neighbouring points, headers kept), as LAS
    and LAZ, and the first lines of the real XYZ files."""
    import laspy

    rng = np.random.default_rng(seed)
    seeds = []
    for rel in SEED_LAZ:
        src = DATA / rel
        if not src.exists():
            continue
        las = laspy.read(str(src))
        x, y = np.asarray(las.x), np.asarray(las.y)
        c = rng.integers(0, len(x))
        d = np.hypot(x - x[c], y - y[c])
        keep = np.argsort(d)[:n_points]
        sub = laspy.LasData(las.header)
        sub.points = las.points[np.sort(keep)].copy()
        for compressed in (False, True):
            out = folder / f"{src.stem}{'.laz' if compressed else '.las'}"
            sub.update_header()
            sub.write(str(out), do_compress=compressed)
            seeds.append(out)
    for rel in SEED_XYZ:
        src = DATA / rel
        if src.exists():
            lines = src.read_text(errors="replace").splitlines()[:n_points]
            out = folder / src.name
            out.write_text("\n".join(lines) + "\n")
            seeds.append(out)
    return seeds


# ------------------------------------------------------------------------------ mutations
#: (offset, struct format) of LAS 1.x header fields
LAS_FIELDS = {"header_size": (94, "<H"), "offset_to_points": (96, "<I"), "n_vlrs": (100, "<I"),
              "point_format": (104, "<B"), "record_length": (105, "<H"),
              "legacy_count": (107, "<I"), "x_scale": (131, "<d"), "y_scale": (139, "<d"),
              "z_scale": (147, "<d"), "x_offset": (155, "<d"), "max_x": (179, "<d"),
              "min_x": (187, "<d"), "max_y": (195, "<d"), "min_z": (219, "<d"),
              "count_14": (247, "<Q"), "version_minor": (25, "<B")}


def boundary_values(fmt: str, old, size: int) -> list:
    if fmt in ("<d",):
        return [0.0, -old, old * 1e6, 1e300, float("nan"), float("inf"), 1e-12]
    big = {"<B": 255, "<H": 65535, "<I": 2 ** 32 - 1, "<Q": 2 ** 63 - 1}[fmt]
    return [0, 1, big, old + 1, max(old - 1, 0), old * 2, size, size - 1, size + 1]


def mutate_las(rng: random.Random, data: bytes) -> tuple:
    b = bytearray(data)
    size = len(b)
    kind = rng.choice(["field", "field", "field", "bytes_header", "bytes_vlr", "bytes_points",
                       "truncate", "repeat", "chunk_table", "zero_tail"])
    if kind == "field":
        name = rng.choice(list(LAS_FIELDS))
        off, fmt = LAS_FIELDS[name]
        if off + struct.calcsize(fmt) > size:
            return bytes(b), "field-out-of-range"
        old = struct.unpack_from(fmt, b, off)[0]
        val = rng.choice(boundary_values(fmt, old, size))
        if fmt != "<d":
            val = int(val) % (1 << (8 * struct.calcsize(fmt)))
        struct.pack_into(fmt, b, off, val)
        return bytes(b), f"{name}={val}"
    if kind == "bytes_header":
        for _ in range(rng.randint(1, 8)):
            b[rng.randrange(0, min(size, 375))] = rng.randrange(256)
        return bytes(b), kind
    if kind == "bytes_vlr":
        start = struct.unpack_from("<H", b, 94)[0]
        end = struct.unpack_from("<I", b, 96)[0]
        if start < end <= size:
            for _ in range(rng.randint(1, 16)):
                b[rng.randrange(start, end)] = rng.randrange(256)
        return bytes(b), kind
    if kind == "bytes_points":
        start = min(struct.unpack_from("<I", b, 96)[0], size - 1)
        n = rng.randint(1, 4096)
        pos = rng.randrange(start, size)
        b[pos:pos + n] = bytes(rng.randrange(256) for _ in range(min(n, size - pos)))
        return bytes(b), kind
    if kind == "truncate":
        cut = rng.randrange(0, size)
        return bytes(b[:cut]), f"truncate@{cut}"
    if kind == "repeat":
        a = rng.randrange(0, size)
        n = rng.randint(1, 20000)
        return bytes(b[:a] + b[a:a + n] + b[a:]), f"repeat@{a}+{n}"
    if kind == "chunk_table":  # LAZ: the 8 bytes at the start of the points give its offset
        start = struct.unpack_from("<I", b, 96)[0]
        if start + 8 <= size:
            ct = struct.unpack_from("<q", b, start)[0]
            if rng.random() < 0.5 or not 0 < ct < size:
                struct.pack_into("<q", b, start, rng.choice([0, -1, size, size + 8, ct // 2, 2 ** 62]))
            else:
                for k in range(ct, min(size, ct + rng.randint(1, 64))):
                    b[k] = rng.randrange(256)
        return bytes(b), kind
    return bytes(b[: size // 2]) + bytes(size - size // 2), kind


def mutate_text(rng: random.Random, text: str) -> tuple:
    lines = text.splitlines()
    kind = rng.choice(["decimal_comma", "thousands", "bom", "tokens", "drop_col", "shuffle",
                       "add_col", "delimiter", "crlf", "junk", "empty", "header", "huge",
                       "duplicate"])
    rows = [ln.split() for ln in lines]
    if kind == "decimal_comma":
        out = "\n".join("\t".join(v.replace(".", ",") for v in r) for r in rows)
    elif kind == "thousands":
        def th(v):
            try:
                f = float(v)
            except ValueError:
                return v
            return f"{f:,.2f}".replace(",", "X").replace(".", ",").replace("X", ".") \
                if rng.random() < 0.5 else f"{f:,.3f}"
        out = "\n".join(";".join(th(v) for v in r) for r in rows)
    elif kind == "bom":
        out = "\ufeff" + text
    elif kind == "tokens":
        tok = ["nan", "NaN", "inf", "-inf", "1e999", "--", "", "0x1F", "1,2,3", "nulo", "\x00"]
        for _ in range(rng.randint(1, 30)):
            r = rng.choice(rows) if rows else []
            if r:
                r[rng.randrange(len(r))] = rng.choice(tok)
        out = "\n".join(" ".join(r) for r in rows)
    elif kind == "drop_col":
        k = rng.randrange(3)
        out = "\n".join(" ".join(v for j, v in enumerate(r) if j != k) for r in rows)
    elif kind == "shuffle":
        perm = list(range(max((len(r) for r in rows), default=3)))
        rng.shuffle(perm)
        out = "\n".join(" ".join(r[j] for j in perm if j < len(r)) for r in rows)
    elif kind == "add_col":
        out = "\n".join(" ".join(r + [str(rng.random())] * rng.randint(1, 9)) for r in rows)
    elif kind == "delimiter":
        d = rng.choice([",", ";", "|", "  ", "\t\t", ", ", ":"])
        out = "\n".join(d.join(r) for r in rows)
    elif kind == "crlf":
        out = "\r\n".join(lines) + "\r"
    elif kind == "junk":
        raw = bytearray(text.encode())
        for _ in range(rng.randint(1, 50)):
            if raw:
                raw[rng.randrange(len(raw))] = rng.randrange(256)
        return raw, kind
    elif kind == "empty":
        out = "\n" * rng.randint(0, 5)
    elif kind == "header":
        out = rng.choice(["X Y Z", "x;y;z;intensidade", "# comentário", "E N H"]) + "\n" + text
    elif kind == "huge":
        out = "\n".join(" ".join(str(float(v) * 10 ** rng.randint(3, 12)) if v.replace(".", "")
                                 .replace("-", "").isdigit() else v for v in r) for r in rows)
    else:
        out = "\n".join(lines * rng.randint(2, 4))
    return out.encode("utf-8", errors="replace"), kind


# ------------------------------------------------------------------------------ commands
COMMAND_WEIGHTS = {"info": 4, "grid": 3, "chm": 3, "trees": 3, "ground": 2, "compare": 1,
                   "stem": 1, "profile": 1}


def option_value(rng: random.Random, p, folder: Path) -> str | None:
    if p.kind == "bool":
        return None
    if p.choices:
        return rng.choice(list(p.choices) + ["", "XYZ", p.choices[0].upper()])
    if p.kind in ("float", "res", "int"):
        return rng.choice(["0", "-1", "1e-9", "1e9", "nan", "inf", "0.5", "2", "abc", "1,5",
                           "", "3x2", str(rng.uniform(-5, 50))])
    if p.kind in ("output",) or p.name.endswith("_out") or p.name in ("png", "csv"):
        return str(folder / rng.choice(["o.tif", "o.gpkg", "o.csv", "sub/none/o.tif", "o"]))
    return rng.choice(["", "auto", "none", "3x2", "0", "EPSG:31984", "EPSG:99999", "SAD69 24K",
                       "tcp://127.0.0.1:9", str(folder / "missing.tif"), "1,2", "lowest:0",
                       "kp:-1:x", "ws", "gauss:0", "-5"])


def make_argv(rng: random.Random, inp: Path, folder: Path) -> list:
    from lidartrees_gis.cli.commands import COMMANDS

    name = rng.choices(list(COMMAND_WEIGHTS), weights=list(COMMAND_WEIGHTS.values()))[0]
    cmd = COMMANDS[name]
    argv = [name, str(inp)]
    for p in cmd.params:
        if p.positional and p.name != "input":
            argv.append(str(folder / {"output": "out", "prefix": "stem", "outdir": "dir"}
                            .get(p.name, "x")) + (".gpkg" if name == "trees" else
                                                   ".tif" if name in ("grid", "chm", "ground")
                                                   else ".csv"))
    opts = [p for p in cmd.params if not p.positional and p.name not in ("scheduler", "workers")]
    for p in rng.sample(opts, k=min(len(opts), rng.choice([0, 0, 1, 1, 2, 3]))):
        v = option_value(rng, p, folder)
        argv.append(p.flag)
        if v is not None:
            argv.append(v)
    flags = {f for p in cmd.params for f in (p.flag, *p.aliases) if f}
    if "-a_srs" in flags and rng.random() < 0.5:
        argv += ["-a_srs", "EPSG:31984"]
    if "--allow-no-crs" in flags and rng.random() < 0.5:
        argv.append("--allow-no-crs")
    if "-workers" in flags:
        argv += ["-workers", "1"]
    return argv + ["-q"]


# ------------------------------------------------------------------------------ running
def _child(argv, out_path) -> None:
    """In the forked process: run the CLI, record the exit code or the escaped exception."""
    os.setsid()
    fd = os.open(out_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    from lidartrees_gis.cli import main

    code, tb = None, None
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 2
    except BaseException:  # noqa: BLE001 - an escaped exception is what we look for
        tb = traceback.format_exc()
    with open(str(out_path) + ".verdict", "w") as fh:
        json.dump({"code": code, "traceback": tb}, fh)
    os._exit(0)


def start_case(argv, workdir: Path) -> dict:
    """Fork a process running the case; returns what :func:`finish_case` needs."""
    out = workdir / "stdout.txt"
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child
        try:
            _child(argv, out)
        finally:
            os._exit(3)
    return {"pid": pid, "t0": time.perf_counter(), "argv": argv, "out": out}


def poll_case(case: dict, time_limit=TIME_LIMIT) -> dict | None:
    """The case's result once its process ended (or was killed over the time limit)."""
    done, status = os.waitpid(case["pid"], os.WNOHANG)
    hang = False
    if not done:
        if time.perf_counter() - case["t0"] <= time_limit:
            return None
        hang = True
        os.killpg(case["pid"], signal.SIGKILL)
        _, status = os.waitpid(case["pid"], 0)
    dt = time.perf_counter() - case["t0"]
    out = case["out"]
    text = out.read_text(errors="replace") if out.exists() else ""
    vpath = Path(str(out) + ".verdict")
    verdict = json.loads(vpath.read_text()) if vpath.exists() else {}
    sig = os.WTERMSIG(status) if not hang and os.WIFSIGNALED(status) else None
    kind = ("hang" if hang else "abort" if sig else "traceback" if verdict.get("traceback")
            or "Traceback (most recent call last)" in text else
            "no-verdict" if not verdict else None)
    return {"argv": case["argv"], "seconds": round(dt, 3), "code": verdict.get("code"),
            "signal": sig, "failure": kind,
            "last_line": text.strip().splitlines()[-1][:300] if text.strip() else "",
            "traceback": (verdict.get("traceback") or "")[-2000:]}


def fuzz(n_cases: int, seed: int, jobs: int, root: Path, first: int = 0) -> dict:
    rng = random.Random(seed)
    for _ in range(first):  # replay from case `first` of this seed
        rng.random()
    seeds_dir = root / "seeds"
    seeds_dir.mkdir(parents=True, exist_ok=True)
    pid = os.fork()  # the seeds are written in a child: laspy's LAZ writer starts threads
    if pid == 0:  # pragma: no cover - the child
        try:
            make_seeds(seeds_dir, seed=seed)
        finally:
            os._exit(0)
    os.waitpid(pid, 0)
    seeds = sorted(seeds_dir.iterdir())
    if not seeds:
        raise SystemExit(f"no seed file made from {DATA} (set LIDARTREES_DATA to the shared data)")
    # import once before forking, but run nothing here: a run starts threads (the LAZ
    # decoder's, numba's), and a process forked from a threaded one may inherit a held lock
    # and hang (every "hang" of a first version was that, on unmutated files)
    import lidartrees_gis.als.chain  # noqa: F401
    import lidartrees_gis.cli  # noqa: F401
    import lidartrees_gis.ground  # noqa: F401

    assert len(os.listdir("/proc/self/task")) == 1, "a thread was started before forking"
    results, failures, t0 = [], [], time.time()

    def prepare(i):
        case_rng = random.Random(rng.random())
        d = root / f"case{i}"
        shutil.rmtree(d, ignore_errors=True)
        d.mkdir(parents=True)
        src = case_rng.choice(seeds)
        data = src.read_bytes()
        if src.suffix.lower() in (".las", ".laz"):
            data, what = mutate_las(case_rng, data) if case_rng.random() < 0.9 else (data, "none")
        else:
            data, what = mutate_text(case_rng, data.decode(errors="replace")) \
                if case_rng.random() < 0.9 else (data, "none")
        suffix = src.suffix if case_rng.random() < 0.95 else case_rng.choice([".xyz", ".las", ".csv", ""])
        inp = d / f"input{suffix}"
        inp.write_bytes(bytes(data))
        return d, make_argv(case_rng, inp, d), f"{src.name}:{what}"

    running, i = [], first
    n_cases += first
    while i < n_cases or running:
        while i < n_cases and len(running) < jobs:
            d, argv, what = prepare(i)
            running.append((start_case(argv, d), what, d, i))
            i += 1
        still = []
        for case, what, d, k in running:
            r = poll_case(case)
            if r is None:
                still.append((case, what, d, k))
            else:
                _collect(r, what, d, k, results, failures, root)
                shutil.rmtree(d, ignore_errors=True)
        running = still
        time.sleep(0.003)
    secs = [r["seconds"] for r in results]
    return {"cases": len(results), "seed": seed, "wall_s": round(time.time() - t0, 1),
            "aborts": sum(r["failure"] == "abort" for r in results),
            "hangs": sum(r["failure"] == "hang" for r in results),
            "tracebacks": sum(r["failure"] == "traceback" for r in results),
            "no_verdict": sum(r["failure"] == "no-verdict" for r in results),
            "exit_codes": {str(c): sum(r["code"] == c for r in results)
                           for c in sorted({r["code"] for r in results}, key=str)},
            "mutations": len({r["mutation"] for r in results}),
            "slowest_s": max(secs) if secs else None,
            "median_s": float(np.median(secs)) if secs else None,
            "failures": failures[:50]}


def _collect(r, what, d, i, results, failures, root):
    r["mutation"] = what
    results.append(r)
    if r["failure"]:
        keep = root / "failures" / f"case{i}"
        shutil.copytree(d, keep, dirs_exist_ok=True)
        r["kept"] = str(keep)
        failures.append(r)
        print(f"case {i}: {r['failure']}: {' '.join(r['argv'])} ({what})", file=sys.stderr)
    if len(results) % 500 == 0:
        print(f"{len(results)} cases, {len(failures)} failures", file=sys.stderr)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--first", type=int, default=0, help="start at this case of the seed (replay)")
    ap.add_argument("--dir", default=None, help="work folder (default: a temporary one)")
    ap.add_argument("--out", default=str(HERE / "results" / "fuzz_independent.json"))
    a = ap.parse_args(argv)
    root = Path(a.dir) if a.dir else Path(tempfile.mkdtemp(prefix="lidartrees-fuzz-"))
    summary = fuzz(a.cases, a.seed, a.jobs, root, a.first)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(summary, indent=1, default=str))
    print(json.dumps({k: v for k, v in summary.items() if k != "failures"}, indent=1))
    return 0 if not (summary["aborts"] or summary["hangs"] or summary["tracebacks"]) else 1


if __name__ == "__main__":
    sys.exit(main())

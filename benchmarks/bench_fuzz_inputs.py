"""Issue 42's fuzz campaign of the inputs to refuse or warn about
(:mod:`lidartrees_gis.fuzz_inputs`): as many cases as fit in a wall-clock budget, in batches of
independent seeds, written to ``benchmarks/results/fuzz.json``.

    python benchmarks/bench_fuzz_inputs.py --minutes 15 --batch 300 --seed 1000
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(argv=None) -> int:
    from lidartrees_gis.fuzz_inputs import campaign

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=15.0)
    ap.add_argument("--batch", type=int, default=300)
    ap.add_argument("--seed", type=int, default=1000)
    ap.add_argument("--out", default=str(HERE / "results" / "fuzz.json"))
    a = ap.parse_args(argv)
    t0, seed, batches = time.perf_counter(), a.seed, []
    while time.perf_counter() - t0 < a.minutes * 60:
        with tempfile.TemporaryDirectory(prefix="lidartrees-fuzz-") as tmp:
            rep = campaign(a.batch, seed, tmp)
        batches.append(rep)
        print(f"seed {seed}: {rep['cases']} cases, {rep['failed']} failed, "
              f"{rep['wall_s']} s", file=sys.stderr)
        seed += 1
        write(batches, t0, a.out)  # after every batch: a killed campaign keeps what it ran
    total = write(batches, t0, a.out)
    print(json.dumps({k: v for k, v in total.items() if k != "failures"}, indent=1))
    return 0


def write(batches: list, t0: float, path) -> dict:
    """The campaign's totals over its ``batches``, written to ``path``."""
    total = {"cases": sum(b["cases"] for b in batches), "seeds": [b["seed"] for b in batches],
             "failed": sum(b["failed"] for b in batches),
             "tracebacks": sum(b["by_reason"].get("traceback", 0) for b in batches),
             "hangs_over_30s": sum(b["by_reason"].get("hang", 0) + b["by_reason"].get("slow", 0)
                                   for b in batches),
             "memory_over_4gb": sum(b["by_reason"].get("memory", 0) for b in batches),
             "differ_over_5pct_without_warning": sum(
                 v for b in batches for k, v in b["by_reason"].items()
                 if k in ("trees", "shape", "ground", "crs", "no")),
             "exit0_on_refusable": sum(b["by_reason"].get("exit 0 on an input to refuse", 0)
                                       for b in batches),
             "refused": sum(b["refused"] for b in batches), "ran": sum(b["ran"] for b in batches),
             "slowest_s": max(b["slowest_s"] for b in batches),
             "max_rss_gb": max(b["max_rss_gb"] for b in batches),
             "wall_s": round(time.perf_counter() - t0, 1),
             "failures": [f for b in batches for f in b["failures"]][:50]}
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"fuzz_inputs": total}, indent=1, default=str))
    return total


if __name__ == "__main__":
    sys.exit(main())

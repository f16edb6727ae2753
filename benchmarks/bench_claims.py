"""Two ``lidartrees trees`` runs started together on one output, 20 trials of each race
(issue 42): a new output without -overwrite (one run wins, the other refuses in one line) and
two -append runs into one GeoPackage (both land: the layer's count is the sum).

    python benchmarks/bench_claims.py --trials 20

writes ``benchmarks/results/claims.json``.
"""
from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

from _races import check_appends, check_new_output, make_inputs, race  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--out", default=str(HERE / "results" / "claims.json"))
    a = ap.parse_args(argv)
    report = {"trials": a.trials}
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        inputs = make_inputs(d)
        for kind, extra, check in (("new_output", ("-q",), check_new_output),
                                   ("append", ("-append", "-q"), check_appends)):
            t0, faults, exits, refusals = time.time(), [], Counter(), Counter()
            for t in range(a.trials):
                out = d / f"{kind}_{t}.gpkg"
                res = race(inputs, out, *extra)
                exits["+".join(str(r[0]) for r in sorted(res))] += 1
                for rc, _, err in res:
                    if rc:
                        msg = err[-1].split(": error: ", 1)[-1] if err else ""
                        msg = re.sub(r"\S+\.gpkg", "OUT.gpkg", msg)
                        refusals[re.sub(r"process \d+ on \S+\)", "process N on HOST)", msg)] += 1
                fault = check(res, out)
                if fault:
                    faults.append(f"trial {t}: {fault}")
            report[kind] = {"faults": faults, "exit_codes": dict(exits),
                            "refusals": dict(refusals), "seconds": round(time.time() - t0, 1)}
            print(kind, report[kind], flush=True)
    Path(a.out).write_text(json.dumps(report, indent=1) + "\n")
    return 1 if any(report[k]["faults"] for k in ("new_output", "append")) else 0


if __name__ == "__main__":
    sys.exit(main())

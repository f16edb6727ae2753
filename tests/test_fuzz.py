"""Issue 11 acceptance: a seeded fuzz run of 2,000 malformed inputs and odd parameters through
the CLI (mutated XYZ text, LAS/LAZ with broken headers and records, corrupt gzip, files that are
not point data): no traceback, no signal, no case over 20 s, every failure one line, exit 1."""
from lidartrees_gis.fuzz import TIME_LIMIT, make_cases, run_cases, verdict


def test_fuzz_2000_cases(tmp_path):
    cases = make_cases(2000, seed=0, workdir=tmp_path)
    kinds = {c["label"].split("/")[0] for c in cases}
    assert kinds == {"xyz", "las", "laz", "other", "args"}
    results = run_cases(cases, time_limit=TIME_LIMIT)
    assert len(results) == 2000
    failures = [(r["id"], r["label"], " ".join(r["argv"]), v, r["stderr"][-300:])
                for r in results if (v := verdict(r))]
    assert not failures, failures[:10]
    # the run exercised both outcomes: clean refusals and successful runs
    codes = [r["code"] for r in results]
    assert codes.count(1) > 500 and codes.count(0) > 100

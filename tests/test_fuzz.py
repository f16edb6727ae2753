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


def test_fuzz_inputs_to_refuse_or_warn(tmp_path):
    """Issue 42: a seeded run of every family of inputs the project must refuse or warn about
    (far points, conflicting CRS records, nodata borders, degenerate clouds, extreme numbers,
    bad creation options): no traceback, hang or memory blow-up, no exit 0 on a degenerate
    input, no result more than 5 % off the unmutated one without a warning."""
    from lidartrees_gis.fuzz_inputs import FAMILIES, campaign

    rep = campaign(36, seed=0, workdir=tmp_path)
    assert rep["cases"] == 36 and set(rep["families"]) == set(FAMILIES)
    assert all(v == 6 for v in rep["families"].values())
    assert rep["failed"] == 0, rep["failures"][:5]
    assert rep["refused"] >= 10 and rep["ran"] >= 6  # both outcomes exercised

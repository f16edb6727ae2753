"""Issue 42: outputs claimed, not raced. Two runs writing one new output without -overwrite
both exited 0 and one result silently replaced the other; two -append runs into one GeoPackage
both exited 0 and one appended layer was lost (14 of 14 trials)."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

from _races import check_appends, check_new_output, make_inputs, race
from lidartrees_gis.errors import OutputError, OutputExistsError
from lidartrees_gis.io.claim import claim_output, lock_file, place
from lidartrees_gis.io.output import atomic_output

#: trials per race in the suite (benchmarks/bench_claims.py runs 20 of each)
TRIALS = int(os.environ.get("LIDARTREES_RACE_TRIALS", 3))


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    return make_inputs(tmp_path_factory.mktemp("race"))


def test_two_runs_on_one_new_output_one_wins_the_other_refuses(inputs, tmp_path):
    faults = []
    for t in range(TRIALS):
        out = tmp_path / f"trial_{t}.gpkg"
        faults.append(check_new_output(race(inputs, out, "-q"), out))
    assert faults == [""] * TRIALS
    assert not list(tmp_path.glob(".*"))  # no lock, part file or checkpoint left


def test_two_appends_into_one_geopackage_both_land(inputs, tmp_path):
    faults = []
    for t in range(TRIALS):
        out = tmp_path / f"trial_{t}.gpkg"
        res = race(inputs, out, "-append", "-nln", "", "-q")
        faults.append(check_appends(res, out))
        assert [r[0] for r in res] == [0, 0]  # appends wait for each other: both land
    assert faults == [""] * TRIALS


def _hold(path: Path, seconds: float):
    """Another process holding ``path``'s claim for ``seconds``."""
    code = ("import sys, time; from lidartrees_gis.io.claim import claim_output\n"
            "with claim_output(sys.argv[1]):\n"
            "    print('held', flush=True); time.sleep(float(sys.argv[2]))\n")
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    p = subprocess.Popen([sys.executable, "-c", code, str(path), str(seconds)],
                         stdout=subprocess.PIPE, text=True, env=env)
    assert p.stdout.readline().strip() == "held"
    return p


def test_a_claimed_output_is_refused_in_one_line_naming_the_holder(tmp_path):
    out = tmp_path / "a.tif"
    p = _hold(out, 30)
    try:
        with pytest.raises(OutputError) as e:
            with atomic_output(out) as tmp:
                tmp.write_bytes(b"x")
        msg = str(e.value)
        assert "\n" not in msg and f"process {p.pid}" in msg and "another run" in msg
        assert not out.exists()
    finally:
        p.kill()
        p.wait()
    # the holder was killed: its lock file is taken over
    assert lock_file(out).exists()
    with atomic_output(out) as tmp:
        tmp.write_bytes(b"mine")
    assert out.read_bytes() == b"mine" and not lock_file(out).exists()


def test_an_append_waits_for_the_holder_and_lands(tmp_path):
    out = tmp_path / "a.gpkg"
    p = _hold(out, 1.5)
    with pytest.warns(UserWarning, match="waiting for it to end"):
        with atomic_output(out, append=True) as tmp:
            assert p.poll() is not None  # the holder has finished
            tmp.write_bytes(b"appended")
    p.wait()
    assert out.read_bytes() == b"appended"


def test_the_final_rename_never_replaces_an_output_that_appeared_meanwhile(tmp_path):
    out = tmp_path / "a.csv"
    with pytest.raises(OutputExistsError, match="written meanwhile by another run"):
        with atomic_output(out) as tmp:
            tmp.write_text("mine")
            out.write_text("theirs")  # another program, not through a claim
    assert out.read_text() == "theirs"
    assert [f.name for f in tmp_path.iterdir()] == ["a.csv"]  # no part file left
    src = tmp_path / "b"
    src.write_text("b")
    with pytest.raises(OutputExistsError):
        place(src, out, replace=False)
    place(src, out, replace=True)
    assert out.read_text() == "b"


def test_a_claim_is_reentrant_in_one_thread(tmp_path):
    out = tmp_path / "a.gpkg"
    with claim_output(out):
        with atomic_output(out) as tmp:  # the chain claims first, then writes
            tmp.write_bytes(b"x")
        assert lock_file(out).exists()
    assert out.exists() and not lock_file(out).exists()


def test_ground_refuses_an_output_another_run_writes(inputs, tmp_path, capsys):
    from lidartrees_gis.cli import main

    out = tmp_path / "classified.las"
    p = _hold(out, 60)
    try:
        capsys.readouterr()
        assert main(["ground", str(inputs[0]), str(out), "-q"]) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "is being written by another run" in err[0]
        assert not out.exists()
    finally:
        p.kill()
        p.wait()
    assert main(["ground", str(inputs[0]), str(out), "-q"]) == 0
    assert out.exists() and not lock_file(out).exists()
    assert main(["ground", str(inputs[0]), str(out), "-q"]) == 1  # exists: no -overwrite

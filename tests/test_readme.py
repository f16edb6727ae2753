"""The README's examples, run as written, print the figures the README shows.

A ``console`` block is a session: ``$ command`` lines (a trailing backslash continues one) run
in bash in one folder, with ``lidartrees`` this checkout's CLI; the lines after a command are
what it prints, ``...`` standing for any lines left out; every other line must be printed as
shown, in that order, next to its neighbours. A ``python`` block followed by a ``text`` block
must print that text. The ``bash`` blocks name make targets and scripts that exist, and every
relative link of the README and docs/ leads to a file.
"""
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from _paths import DATA

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"


def fenced_blocks(text: str) -> list:
    """``(language, body)`` of each fenced code block, in order."""
    return [(m.group(1), m.group(2)) for m in
            re.finditer(r"^```(\w*)\n(.*?)^```\s*$", text, flags=re.M | re.S)]


def console_steps(body: str) -> list:
    """``(command, expected lines)`` of a console block."""
    steps = []
    lines = body.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        assert line.startswith("$ "), f"console block: output before a command: {line!r}"
        cmd = line[2:]
        while cmd.endswith("\\"):
            i += 1
            cmd = cmd[:-1] + lines[i].strip()
        i += 1
        out = []
        while i < len(lines) and not lines[i].startswith("$ "):
            out.append(lines[i])
            i += 1
        steps.append((cmd, out))
    return steps


def matches(expected: list, printed: list) -> bool:
    """Whether ``printed`` holds ``expected``: its runs between ``...`` lines contiguous and in
    order, anchored at the start and end unless ``...`` is there."""
    if not expected:
        return True
    runs, run = [], []
    for line in expected:
        if line == "...":
            runs.append(run)
            run = []
        else:
            run.append(line)
    runs.append(run)
    pos = 0
    for k, run in enumerate(runs):
        if not run:
            continue
        starts = [pos] if k == 0 else range(pos, len(printed) - len(run) + 1)
        for s in starts:
            if printed[s:s + len(run)] == run:
                pos = s + len(run)
                break
        else:
            return False
    return pos == len(printed) or expected[-1] == "..."


def test_matching_rule():
    printed = ["a: 1", "b: 2", "c: 3", "d: 4"]
    assert matches(["a: 1", "...", "c: 3", "..."], printed)
    assert matches(["...", "d: 4"], printed)
    assert not matches(["a: 1", "c: 3", "..."], printed)  # not neighbours
    assert not matches(["...", "c: 3"], printed)  # not the last line
    assert not matches(["...", "b: 3", "..."], printed)  # another figure
    assert not matches(["...", "c: 3", "...", "a: 1", "..."], printed)  # order


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """A folder where ``lidartrees`` is this checkout's CLI (as ``make demo`` installs it)."""
    d = tmp_path_factory.mktemp("readme")
    bindir = d / ".bin"
    bindir.mkdir()
    exe = bindir / "lidartrees"
    exe.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m lidartrees_gis.cli "$@"\n')
    exe.chmod(0o755)
    env = dict(os.environ, PATH=f"{bindir}:{os.environ['PATH']}",
               PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    if (DATA / "lasR_bcts").is_dir():
        (d / "lasR_bcts").symlink_to(DATA / "lasR_bcts")
    return d, env


def _run_session(body, workdir):
    d, env = workdir
    for cmd, expected in console_steps(body):
        r = subprocess.run(["bash", "-c", cmd], cwd=d, env=env, capture_output=True, text=True,
                           timeout=900)
        assert r.returncode == 0, f"{cmd}\n{r.stderr[-2000:]}"
        printed = r.stdout.splitlines()
        assert matches(expected, printed), f"{cmd} printed:\n{r.stdout}"


def _sessions():
    return [b for lang, b in fenced_blocks(README.read_text(encoding="utf-8"))
            if lang == "console"]


def _ensure_demo(workdir):
    d, env = workdir
    if not (d / "lidartrees_demo" / "talhoes.gpkg").exists():
        subprocess.run(["bash", "-c", "lidartrees demo lidartrees_demo -q"], cwd=d, env=env,
                       check=True, capture_output=True, timeout=900)


def test_readme_has_its_four_quick_starts():
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) < 150
    heads = re.findall(r"^## (.+)$", text, flags=re.M)
    assert [h for h in heads if h.startswith("Quick start")] == [
        "Quick start 1: XYZ text and talhões", "Quick start 2: a folder of LAS/LAZ tiles",
        "Quick start 3: QGIS", "Quick start 4: Python"]
    assert len(_sessions()) == 2


def test_quick_start_xyz_and_talhoes(workdir):
    body = next(b for b in _sessions() if "talhoes.gpkg" in b)
    assert body.startswith("$ lidartrees demo ")  # the session makes its own input
    _run_session(body, workdir)
    d, _ = workdir
    csv = (d / "talhoes.csv").read_text(encoding="utf-8-sig")
    assert "001-A" in csv and "001-B" in csv


@pytest.mark.realdata
def test_quick_start_las_folder(workdir):
    if not (DATA / "lasR_bcts").is_dir():
        pytest.skip(f"no {DATA / 'lasR_bcts'}")
    body = next(b for b in _sessions() if "lasR_bcts/" in b)
    _run_session(body, workdir)


def test_quick_start_python(workdir):
    blocks = fenced_blocks(README.read_text(encoding="utf-8"))
    k = next(i for i, (lang, _) in enumerate(blocks) if lang == "python")
    code, (lang, expected) = blocks[k][1], blocks[k + 1]
    assert lang == "text"
    _ensure_demo(workdir)
    d, env = workdir
    r = subprocess.run([sys.executable, "-c", code], cwd=d, env=env, capture_output=True,
                       text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.splitlines() == expected.splitlines()


def test_bash_blocks_name_what_exists():
    text = README.read_text(encoding="utf-8")
    makefile = (ROOT / "Makefile").read_text()
    bash = "\n".join(b for lang, b in fenced_blocks(text) if lang == "bash")
    targets = re.findall(r"^make (\w+)", bash, flags=re.M)
    assert {"demo", "test", "plugin"} <= set(targets)
    for t in targets:
        assert re.search(rf"^{t}:", makefile, flags=re.M), t
    for script in re.findall(r"scripts/\w+\.py", text):
        assert (ROOT / script).is_file(), script
    assert "scripts/build_plugin.py" in re.search(r"^plugin:\n\t(.+)$", makefile,
                                                  flags=re.M).group(1)
    assert (ROOT / ".ci" / "run").read_text().strip().endswith("make test")


def test_links_of_readme_and_docs_lead_to_files():
    for md in [README, *sorted((ROOT / "docs").rglob("*.md"))]:
        for target in re.findall(r"\]\(([^)\s]+)\)", md.read_text(encoding="utf-8")):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue
            path = (md.parent / target.split("#")[0]).resolve()
            assert path.exists(), f"{md.relative_to(ROOT)}: {target}"


def test_portuguese_quick_start_runs_the_same_session(workdir):
    """docs/pt-BR/INICIO_RAPIDO.md shows steps of the README's XYZ + talhões session (checked
    above) with the same figures, and a Python example that runs."""
    pt = (ROOT / "docs" / "pt-BR" / "INICIO_RAPIDO.md").read_text(encoding="utf-8")
    assert "](docs/pt-BR/INICIO_RAPIDO.md)" in README.read_text(encoding="utf-8")
    blocks = fenced_blocks(pt)
    pt_steps = [st for lang, b in blocks if lang == "console" for st in console_steps(b)]
    readme_steps = console_steps(next(b for b in _sessions() if "talhoes.gpkg" in b))
    assert len(pt_steps) == 2 and all(st in readme_steps for st in pt_steps)
    for word in ("talhão", "parcela", "DAP", "falha", "estoque"):
        assert word in pt, word
    code = next(b for lang, b in blocks if lang == "python")
    _ensure_demo(workdir)
    d, env = workdir
    r = subprocess.run([sys.executable, "-c", code], cwd=d, env=env, capture_output=True,
                       text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "001-A" in r.stdout and "001-B" in r.stdout

"""The plugin's Portuguese translation covers every text the provider shows, and the committed
.qm is the compiled .ts (scripts/i18n.py). The QGIS side: tests/qgis/test_i18n.py."""
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TS = ROOT / "provider" / "i18n" / "lidartrees_pt_BR.ts"


def _messages():
    return {m.findtext("source"): m.find("translation")
            for m in ET.parse(TS).getroot().iter("message")}


def test_every_provider_text_has_a_portuguese_translation():
    sys.path.insert(0, str(ROOT))
    from provider.texts import source_strings

    msgs = _messages()
    sources = source_strings()
    assert len(sources) > 200  # names, groups, labels, help of every command, messages
    missing = [s for s in sources if s not in msgs or not (msgs[s].text or "").strip()
               or msgs[s].get("type") in ("unfinished", "vanished")]
    assert not missing, f"untranslated (run scripts/i18n.py update and translate): {missing[:5]}"
    for s in sources:  # str.format placeholders survive the translation
        assert sorted(re.findall(r"\{\w+\}", s)) == \
            sorted(re.findall(r"\{\w+\}", msgs[s].text)), s
    # the field words of a Brazilian inventory
    words = " ".join(msgs[s].text for s in sources)
    for w in ("talhão", "talhões", "falha", "estoque", "DAP", "espaçamento de plantio", "MDT"):
        assert w.lower() in words.lower(), w


def test_committed_qm_is_the_compiled_ts(tmp_path):
    exe = shutil.which("lrelease") or shutil.which("lrelease-qt5")
    if exe is None:
        pytest.skip("lrelease not installed (Debian qttools5-dev-tools)")
    qm = tmp_path / "x.qm"
    subprocess.run([exe, "-silent", str(TS), "-qm", str(qm)], check=True)
    assert qm.read_bytes() == TS.with_suffix(".qm").read_bytes(), "run python scripts/i18n.py"


def test_command_not_found_message_names_an_install_that_works(monkeypatch, tmp_path):
    """The package is not on PyPI: the plugin's message says to install it from its folder or
    wheel, not ``pip install lidartrees_gis`` (which fails)."""
    sys.path.insert(0, str(ROOT))
    from provider import _lib

    monkeypatch.delenv("LIDARTREES_EXE", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.setenv("HOME", str(tmp_path))
    msg = _lib.executable_error()
    assert "'lidartrees' command was not found" in msg
    assert "pip install /path/to/lidartrees_gis" in msg and "install lidartrees_gis " not in msg
    assert "lidartrees_gis-*.whl" in msg and "not published on PyPI" in msg
    assert "LIDARTREES_EXE" in msg and "lidartrees/executable" in msg

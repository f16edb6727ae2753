"""Update the QGIS plugin's translation and compile it.

    python scripts/i18n.py            # update provider/i18n/lidartrees_pt_BR.ts, then compile .qm
    python scripts/i18n.py update     # only the .ts: add new texts (unfinished), mark gone ones
    python scripts/i18n.py release    # only the .qm, with Qt's lrelease

The provider's texts are built at run time from the command table, so Qt's ``lupdate`` cannot
find them in the code: ``provider.texts.source_strings()`` lists them, and ``update`` merges that
list into each ``.ts`` file (translations kept; a new or changed English text comes in as
``unfinished``, to translate in Qt Linguist or any editor; a text no longer used is marked
``vanished``). ``release`` runs ``lrelease`` (Debian: ``apt-get install qttools5-dev-tools``);
the ``.qm`` is committed, so building the plugin needs no Qt tools.
"""
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
I18N = ROOT / "provider" / "i18n"
LANGUAGES = ("pt_BR",)


def ts_path(lang: str) -> Path:
    return I18N / f"lidartrees_{lang}.ts"


def read_ts(path: Path) -> dict:
    """``{English text: translation or ''}`` of a .ts file (all contexts, vanished ones too)."""
    if not path.exists():
        return {}
    out = {}
    for msg in ET.parse(path).getroot().iter("message"):
        src, tr = msg.findtext("source") or "", msg.find("translation")
        out[src] = (tr.text or "") if tr is not None else ""
    return out


def write_ts(path: Path, lang: str, sources, known: dict) -> dict:
    """Write ``sources`` with their translations from ``known``; texts of ``known`` no longer
    in ``sources`` follow as vanished. Returns counts."""
    from provider.texts import CONTEXT

    root = ET.Element("TS", version="2.1", language=lang, sourcelanguage="en")
    ctx = ET.SubElement(root, "context")
    ET.SubElement(ctx, "name").text = CONTEXT
    counts = {"finished": 0, "unfinished": 0, "vanished": 0}
    rows = [(s, known.get(s, ""), None) for s in sources]
    rows += [(s, t, "vanished") for s, t in known.items() if s not in set(sources) and t]
    for src, text, kind in rows:
        msg = ET.SubElement(ctx, "message")
        ET.SubElement(msg, "source").text = src
        tr = ET.SubElement(msg, "translation")
        tr.text = text
        kind = kind or (None if text else "unfinished")
        if kind:
            tr.set("type", kind)
        counts[kind or "finished"] += 1
    ET.indent(root)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".ts.part")
    with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
        fh.write('<?xml version="1.0" encoding="utf-8"?>\n<!DOCTYPE TS>\n')
        fh.write(ET.tostring(root, encoding="unicode") + "\n")
    tmp.replace(path)
    return counts


def update(lang: str) -> dict:
    sys.path.insert(0, str(ROOT))
    from provider.texts import source_strings

    path = ts_path(lang)
    return write_ts(path, lang, source_strings(), read_ts(path))


def release(lang: str) -> Path:
    exe = shutil.which("lrelease") or shutil.which("lrelease-qt5")
    if exe is None:
        sys.exit("lrelease not found: apt-get install qttools5-dev-tools (Debian/Ubuntu)")
    qm = ts_path(lang).with_suffix(".qm")
    subprocess.run([exe, "-silent", str(ts_path(lang)), "-qm", str(qm)], check=True)
    return qm


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "all"
    if what not in ("all", "update", "release"):
        sys.exit(__doc__)
    for lang in LANGUAGES:
        if what in ("all", "update"):
            print(ts_path(lang).relative_to(ROOT), update(lang))
        if what in ("all", "release"):
            print(release(lang).relative_to(ROOT))

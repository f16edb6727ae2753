"""Build the QGIS plugin zip (installable with Plugins > Install from ZIP).

    python scripts/build_plugin.py [dist/lidartrees_qgis.zip]

The zip holds one folder, ``lidartrees_qgis/``: the provider (provider/), its translations
(provider/i18n/*.qm), the styles (styles/*.qml)
and a copy of the ``lidartrees_gis`` library, so only third-party packages must be installed into
QGIS's Python.
"""
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = "lidartrees_qgis"


def build(out) -> Path:
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".zip.part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for base, prefix in ((ROOT / "provider", PLUGIN), (ROOT / "lidartrees_gis", f"{PLUGIN}/lidartrees_gis")):
            for f in sorted(base.rglob("*.py")) + sorted(base.glob("metadata.txt")):
                if "__pycache__" not in f.parts:
                    z.write(f, f"{prefix}/{f.relative_to(base)}")
        for f in sorted((ROOT / "provider" / "i18n").glob("*.qm")):  # the translations
            z.write(f, f"{PLUGIN}/i18n/{f.name}")
        for f in sorted((ROOT / "styles").glob("*.qml")):
            z.write(f, f"{PLUGIN}/styles/{f.name}")
        z.write(ROOT / "README.md", f"{PLUGIN}/README.md")
        for f in sorted((ROOT / "docs").rglob("*.md")):  # the README's links, in the zip too
            z.write(f, f"{PLUGIN}/{f.relative_to(ROOT)}")
        z.write(ROOT / "LICENSE", f"{PLUGIN}/LICENSE")
    tmp.replace(out)
    return out


if __name__ == "__main__":
    print(build(sys.argv[1] if len(sys.argv) > 1 else ROOT / "dist" / f"{PLUGIN}.zip"))

"""Start a real headless QGIS (Debian python3-qgis) once per test session and register the
provider. Skipped where QGIS's Python bindings are not importable."""
import os
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
_home = tempfile.mkdtemp(prefix="qgis-home-")
os.chmod(_home, 0o700)
os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
os.environ["XDG_RUNTIME_DIR"] = _home
os.environ["HOME"] = _home

# the provider runs the CLI of the project's main environment (numpy 2), as a user's venv would
_exe = ROOT / ".venv" / "bin" / "lidartrees"
if _exe.exists():
    os.environ.setdefault("LIDARTREES_EXE", str(_exe))

qgis_core = pytest.importorskip("qgis.core")
sys.path.append("/usr/share/qgis/python/plugins")
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


@pytest.fixture(scope="session")
def qgis_app():
    from qgis.core import QgsApplication

    app = QgsApplication([], False)
    app.initQgis()
    from qgis.PyQt.QtCore import QSettings

    # the provider speaks QGIS's language (tests/qgis/test_qgis_i18n.py): English here, whatever LANG
    QSettings().setValue("locale/userLocale", "en_US")
    from processing.core.Processing import Processing

    Processing.initialize()
    from provider.provider import LidarTreesProvider

    prov = LidarTreesProvider()
    QgsApplication.processingRegistry().addProvider(prov)
    yield app, prov
    QgsApplication.processingRegistry().removeProvider(prov)

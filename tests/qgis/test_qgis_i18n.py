"""The provider in Portuguese: with QGIS's ``locale/userLocale`` = pt_BR the algorithms, groups,
parameter labels and help come from provider/i18n/lidartrees_pt_BR.qm; with en_US, English."""
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.qgis
ROOT = Path(__file__).resolve().parents[2]


_KEEP = []  # the providers own their algorithms


def _provider_in(locale):
    """A new provider made while QGIS's language setting is ``locale``: its algorithms."""
    from qgis.PyQt.QtCore import QSettings

    from provider.provider import LidarTreesProvider

    QSettings().setValue("locale/userLocale", locale)
    prov = LidarTreesProvider()
    prov.refreshAlgorithms()
    _KEEP.append(prov)
    return {a.name(): a for a in prov.algorithms()}


@pytest.fixture
def restore_locale(qgis_app):
    from qgis.PyQt.QtCore import QSettings

    from provider.translation import install_translator

    before = QSettings().value("locale/userLocale", "")
    yield
    QSettings().setValue("locale/userLocale", before or "en_US")
    install_translator("en_US")  # the other tests read the English texts


def _labels(alg):
    return {d.name(): d.description() for d in alg.parameterDefinitions()}


def test_provider_speaks_portuguese_when_qgis_does(restore_locale):
    algs = _provider_in("pt_BR")
    trees = algs["trees"]
    assert trees.displayName() == ("Árvores: topos, copas e resumo do talhão (GeoPackage) a "
                                   "partir de pontos ou de um CHM (trees)")
    assert trees.group() == "Árvores" and trees.groupId() == "trees"  # the id stays
    labels = _labels(trees)
    assert labels["SPACING"] == "Espaçamento de plantio (linhas x plantas)"
    assert labels["STANDS"] == "Camada de polígonos dos talhões"
    assert labels["MIN_HEIGHT"] == "Altura mínima da árvore (m)"  # the unit kept
    assert labels["INPUT_LAYER"] == "…ou uma camada de nuvem de pontos carregada no QGIS"
    help_ = trees.shortHelpString()
    assert "Referência:" in help_ and "Linha de comando:" in help_
    assert "cada cova vazia classificada como falha" in help_
    assert "Castro, F. da C. e (2006)" in help_  # citations as published
    assert algs["chm"].group() == "Rasters" and _labels(algs["chm"])["DTM"] == \
        "Modelo digital do terreno (MDT)"
    assert algs["stem"].displayName().startswith("Pontos do tronco, DAP e afilamento")
    assert algs["ground"].group() == "Solo"
    # every algorithm name and parameter label has its Portuguese text
    from provider.texts import english_label

    from lidartrees_gis.cli.commands import COMMANDS

    for name, alg in algs.items():
        cmd = COMMANDS[name]
        assert alg.displayName() != f"{cmd.summary} ({name})", name
        english = {p.name.upper(): english_label(p) + (f" ({p.unit})" if p.unit else "")
                   for p in cmd.params}
        for pid, text in _labels(alg).items():
            assert text != english.get(pid), (name, pid, text)
        assert "Reference:" not in alg.shortHelpString(), name


def test_provider_speaks_english_otherwise(restore_locale):
    _provider_in("pt_BR")
    algs = _provider_in("en_US")  # switching back removes the Portuguese translator
    trees = algs["trees"]
    assert trees.displayName() == ("Tree tops, crowns and a stand summary (GeoPackage) from "
                                   "points or a CHM (trees)")
    assert trees.group() == "Trees"
    assert _labels(trees)["SPACING"] == "Planting spacing (rows x trees)"
    assert "Reference:" in trees.shortHelpString()
    algs = _provider_in("fr_FR")  # a language without a translation: English
    assert algs["trees"].group() == "Trees"


def test_messages_are_translated_with_their_values(restore_locale):
    from provider.texts import tr
    from provider.translation import install_translator

    assert install_translator("pt_BR").endswith("lidartrees_pt_BR.qm")
    msg = tr("Unknown parameter(s) {unknown} for {alg}; its parameters are {known}").format(
        unknown="FOO", alg="trees", known="INPUT, OUTPUT")
    assert msg == ("Parâmetro(s) desconhecido(s) FOO para trees; os parâmetros dele são INPUT, "
                   "OUTPUT")
    assert install_translator("en_US") is None
    assert tr("Number of trees") == "Number of trees"


def test_plugin_zip_carries_the_translation(tmp_path):
    import sys

    sys.path.insert(0, str(ROOT / "scripts"))
    from build_plugin import build

    with zipfile.ZipFile(build(tmp_path / "p.zip")) as z:
        qm = z.read("lidartrees_qgis/i18n/lidartrees_pt_BR.qm")
    assert qm == (ROOT / "provider" / "i18n" / "lidartrees_pt_BR.qm").read_bytes()


def test_installed_plugin_lists_portuguese_names_in_a_portuguese_profile(tmp_path):
    """The zip installed in a fresh QGIS profile whose language is pt_BR (QGIS3.ini, as the
    Options dialog writes it): qgis_process lists the algorithms in Portuguese."""
    import os
    import subprocess
    import sys

    qp = "/usr/bin/qgis_process.bin"
    if not os.path.exists(qp):
        pytest.skip("qgis_process.bin not installed (Debian package qgis)")
    sys.path.insert(0, str(ROOT / "scripts"))
    from build_plugin import build

    plugins, home = tmp_path / "plugins", tmp_path / "home"
    with zipfile.ZipFile(build(tmp_path / "p.zip")) as z:
        z.extractall(plugins)
    ini = home / ".local/share/QGIS/QGIS3/profiles/default/QGIS/QGIS3.ini"
    ini.parent.mkdir(parents=True)
    ini.write_text("[locale]\nuserLocale=pt_BR\noverrideFlag=true\n")
    home.chmod(0o700)
    env = dict(os.environ, QGIS_PLUGINPATH=str(plugins), HOME=str(home),
               XDG_RUNTIME_DIR=str(home), QT_QPA_PLATFORM="offscreen")
    env.pop("PYTHONPATH", None)
    r = subprocess.run([qp, "plugins", "enable", "lidartrees_qgis"], env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    r = subprocess.run([qp, "list"], env=env, capture_output=True, text=True, timeout=120)
    lines = {ln.split("\t")[1]: ln.split("\t")[2] for ln in r.stdout.splitlines()
             if ln.startswith("\tlidartrees:")}
    assert lines["lidartrees:trees"].startswith("Árvores: topos, copas"), r.stdout[-2000:]
    assert lines["lidartrees:stem"].startswith("Pontos do tronco, DAP")

"""The plugin's translations: ``provider/i18n/lidartrees_<locale>.qm`` installed with a
QTranslator when QGIS runs in that language (the usual QGIS plugin pattern).

QGIS's language is the setting ``locale/userLocale`` (e.g. ``pt_BR``); its first two letters
pick the file (``pt`` -> ``lidartrees_pt_BR.qm``, the only one so far). The provider calls
:func:`install_translator` before it creates its algorithms, so their names, groups, parameter
labels and help come out translated. ``scripts/i18n.py`` updates the ``.ts`` file and compiles
the ``.qm``.
"""
import os

HERE = os.path.dirname(os.path.abspath(__file__))
I18N_DIR = os.path.join(HERE, "i18n")
#: the translations shipped, by the language's two letters
LANGUAGES = {"pt": "pt_BR"}

_STATE = {"locale": None, "translator": None}


def user_locale() -> str:
    """QGIS's ``locale/userLocale`` setting; the system's locale when it is unset (as QGIS
    itself does without an override)."""
    from qgis.PyQt.QtCore import QLocale, QSettings

    value = QSettings().value("locale/userLocale", "")
    return value if isinstance(value, str) and value else QLocale.system().name()


def qm_path(locale: str):
    """The compiled translation for ``locale`` (e.g. ``pt_BR`` or ``pt``), or None."""
    lang = LANGUAGES.get((locale or "")[0:2])
    if lang is None:
        return None
    path = os.path.join(I18N_DIR, f"lidartrees_{lang}.qm")
    return path if os.path.isfile(path) else None


def install_translator(locale: str | None = None) -> str | None:
    """Install the translation of ``locale`` (default: QGIS's setting) into the application,
    replacing the one installed before; English (none installed) when there is none. Returns the
    ``.qm`` path installed, or None."""
    from qgis.PyQt.QtCore import QCoreApplication, QTranslator

    locale = user_locale() if locale is None else locale
    path = qm_path(locale)
    if path == _STATE["locale"] and (path is None or _STATE["translator"] is not None):
        return path
    if _STATE["translator"] is not None:
        QCoreApplication.removeTranslator(_STATE["translator"])
        _STATE["translator"] = None
    _STATE["locale"] = path
    if path is None:
        return None
    translator = QTranslator()
    if not translator.load(path):
        _STATE["locale"] = None
        return None
    QCoreApplication.installTranslator(translator)
    _STATE["translator"] = translator  # kept: Qt does not own it
    return path

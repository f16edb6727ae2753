"""The ``lidartrees`` command line and the command table it shares with the QGIS provider.

* :mod:`.commands` — the declarative table: each command's parameters (standard library only,
  read by the QGIS provider without loading numpy or GDAL);
* :mod:`.actions` — what each command runs: its options turned into one library call;
* :mod:`.app` — argument parsing (GDAL/OGR style), progress, messages and exit codes.

``main`` and ``build_parser`` are loaded on first use, so importing :mod:`.commands` loads
nothing else.
"""

__all__ = ["build_parser", "main"]


def __getattr__(name):
    if name in __all__:
        from . import app

        return getattr(app, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

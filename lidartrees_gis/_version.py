"""The version of lidartrees_gis (one place; the package, outputs and the CLI read it)."""

__version__ = "0.1.0"

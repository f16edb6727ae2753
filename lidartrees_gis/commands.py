"""Declarative command table shared by the CLI and the QGIS provider.

Each :class:`Command` lists its :class:`Param` objects once: the ``lidartrees`` CLI builds its
argparse options from them and the QGIS provider builds its processing parameters from them, so
the two cannot drift. ``run(**kwargs, progress=...)`` calls one library function.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from . import pipeline

# kinds: input (point file / raster), output (file), outdir, float, int, str, choice, bool, crs, kv
READ_PARAMS = ()


@dataclass(frozen=True)
class Param:
    """One parameter of a command."""

    name: str  # python keyword and metadata key
    kind: str
    help: str
    flag: str | None = None  # None = positional
    aliases: tuple = ()
    default: object = None
    choices: tuple = ()
    advanced: bool = False
    required: bool = False
    unit: str = ""

    @property
    def positional(self) -> bool:
        return self.flag is None


@dataclass(frozen=True)
class Command:
    """A subcommand: name, group (pipeline stage), summary, parameters and the library call."""

    name: str
    group: str
    summary: str
    params: tuple
    run: Callable
    help: str = ""
    outputs: tuple = field(default=())


INPUT = Param("input", "input", "Point file: LAS/LAZ or XYZ text (tab/space/comma/semicolon, "
              "decimal comma or point, optional header, may be gzip-compressed)")
A_SRS = Param("a_srs", "crs", "Assign this CRS to the input (EPSG code, WKT, PROJ, or SAD69/UTM24S, "
              "'SAD69 24K', SIRGAS2000/UTM24S); required for XYZ text without a .prj",
              flag="-a_srs", aliases=("-s_srs",))
T_SRS = Param("t_srs", "crs", "Reproject the points to this CRS (the operation used and its accuracy "
              "are reported)", flag="-t_srs", advanced=True)
DELIM = Param("delimiter", "str", "XYZ column delimiter: tab, space, comma, semicolon (detected when "
              "not given)", flag="--delimiter", advanced=True)
DECIMAL_COMMA = Param("decimal_comma", "bool", "XYZ numbers use a decimal comma (detected when not "
                      "given)", flag="--decimal-comma", default=None, advanced=True)
COLUMNS = Param("columns", "str", "XYZ column names in order, e.g. x,y,z,intensity,classification "
                "(- skips a column); default from the header or x,y,z", flag="--columns", advanced=True)
SKIP_INVALID = Param("skip_invalid", "bool", "Skip malformed XYZ lines and report how many, instead "
                     "of failing", flag="--skip-invalid", default=False, advanced=True)
RES = Param("res", "res", "Cell size in metres, or auto = sqrt(1/n) from the point density n "
            "(seed 003)", flag="-tr", aliases=("--resolution",), required=True, unit="m")
FILL = Param("fill", "choice", "Gap filling: mean8 = empty cells take the mean of their filled "
             "8-neighbours, repeated until none is empty (seed 000); none = leave nodata",
             flag="-fill", choices=("mean8", "none"), default="mean8")
CO = Param("creation_options", "kv", "GDAL creation option KEY=VALUE for GeoTIFF outputs "
           "(repeatable)", flag="-co", advanced=True)
OVERWRITE = Param("overwrite", "bool", "Replace existing outputs", flag="-overwrite",
                  aliases=("--overwrite",), default=False)
READ = (A_SRS, T_SRS, DELIM, DECIMAL_COMMA, COLUMNS, SKIP_INVALID)


def _info(input, **kw):
    src = pipeline.open_input(input, **_read_kw(kw))
    return pipeline.info(src, progress=kw.get("progress"))


def _read_kw(kw):
    keys = ("a_srs", "t_srs", "delimiter", "decimal_comma", "columns", "skip_invalid")
    return {k: kw[k] for k in keys if kw.get(k) is not None}


def _grid(input, output, **kw):
    return pipeline.grid_file(input, output, res=kw["res"], stat=kw.get("stat") or "max",
                              fill=kw.get("fill") or "none",
                              creation_options=kw.get("creation_options"),
                              overwrite=bool(kw.get("overwrite")), progress=kw.get("progress"),
                              **_read_kw(kw))


def _chm(input, output, **kw):
    return pipeline.chm_file(input, output, res=kw["res"], dtm=kw.get("dtm") or "min",
                             fill=kw.get("fill") or "mean8", dsm_out=kw.get("dsm_out"),
                             dtm_out=kw.get("dtm_out"), creation_options=kw.get("creation_options"),
                             overwrite=bool(kw.get("overwrite")), progress=kw.get("progress"),
                             **_read_kw(kw))


def _demo(outdir=None, **kw):
    from .demo import run_demo

    return run_demo(outdir or "lidartrees_demo", overwrite=bool(kw.get("overwrite")),
                    progress=kw.get("progress"))


COMMANDS = {
    "info": Command(
        "info", "Points", "Points, bounds, density, CRS, classes and returns of a point file",
        (INPUT, *READ, Param("json", "bool", "Print JSON", flag="--json", default=False)), _info),
    "grid": Command(
        "grid", "Rasters", "Grid points into a GeoTIFF with one statistic per cell",
        (INPUT, Param("output", "output", "Output GeoTIFF"), RES,
         Param("stat", "choice", "Per-cell statistic of z", flag="-stat",
               choices=("max", "min", "mean", "count"), default="max"),
         Param("fill", "choice", FILL.help, flag="-fill", choices=("mean8", "none"), default="none"),
         *READ, CO, OVERWRITE), _grid, outputs=("output",)),
    "chm": Command(
        "chm", "Rasters", "Canopy height model CHM = DSM (highest point per cell) - DTM",
        (INPUT, Param("output", "output", "Output CHM GeoTIFF"), RES,
         Param("dtm", "str", "DTM: min = lowest point per cell (seed 000); ground = class-2 points "
               "interpolated (TIN); lowest:R = lowest point per R m cell, interpolated; none = "
               "heights already normalised; auto = ground if classified else lowest:5; or a DTM "
               "GeoTIFF path", flag="-dtm", default="min"),
         FILL,
         Param("dsm_out", "output", "Also write the DSM here", flag="-dsm_out", advanced=True),
         Param("dtm_out", "output", "Also write the DTM here", flag="-dtm_out", advanced=True),
         *READ, CO, OVERWRITE), _chm, outputs=("output", "dsm_out", "dtm_out")),
    "demo": Command(
        "demo", "Demo", "Generate a synthetic eucalyptus stand with known trees and process it",
        (Param("outdir", "outdir", "Output folder (default lidartrees_demo)", default=None,
               required=False), OVERWRITE), _demo),
}

"""Declarative command table shared by the CLI and the QGIS provider.

Each :class:`Command` lists its :class:`Param` objects once: the ``lidartrees`` CLI builds its
argparse options from them and the QGIS provider builds its processing parameters from them, so
the two cannot drift. ``run(**kwargs, progress=...)`` calls one library function.
"""
from __future__ import annotations

from dataclasses import dataclass, field

# This module imports nothing beyond the standard library at load time: the QGIS provider reads
# the parameter table from it without loading numpy, GDAL or GEOS into the QGIS process.

# kinds: input (point file / raster), output (file), outdir, float, int, str, choice, bool, crs, kv,
# vector (a polygon or point layer), field (a field of the vector parameter named by `parent`),
# table (a tabular file: CSV/TXT/XLSX)


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
    parent: str = ""  # kind field: the vector parameter whose field it names

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
    action: str  # the function of :mod:`lidartrees_gis.cli.actions` that runs it
    help: str = ""
    outputs: tuple = field(default=())
    #: files the command writes beside its outputs, named in its result under these keys:
    #: (key, kind raster|file, label); QGIS declares them as the algorithm's outputs
    files: tuple = field(default=())

    def run(self, **kw):
        """Run the command with parameter values ``kw`` (names as in :attr:`params`, plus
        ``progress``); returns the library call's result dict."""
        from . import actions

        return getattr(actions, self.action)(**kw)


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
                "(- skips a column); default from the header or x,y,z", flag="--columns",
                aliases=("-columns",), advanced=True)
SKIP_INVALID = Param("skip_invalid", "bool", "Skip malformed XYZ lines and report how many, instead "
                     "of failing", flag="--skip-invalid", default=False, advanced=True)
#: the -lco options of the tables for people (lidartrees_gis.io.tables)
TABLE_LCO = ("CSV table option KEY=VALUE: SEPARATOR=COMMA|SEMICOLON|TAB|SPACE, "
             "DECIMAL=POINT|COMMA, WRITE_BOM=YES|NO (default: the locale's; pt_BR: semicolon, "
             "decimal comma, BOM); a table named .xlsx is a workbook")
RES = Param("res", "res", "Cell size in metres, or auto = sqrt(1/n) from the point density n "
            "(Leite et al.)", flag="-tr", aliases=("--resolution",), default="auto", unit="m")
FILL = Param("fill", "choice", "Gap filling: mean8 = empty cells take the mean of their filled "
             "8-neighbours, repeated until none is left (Castro 2006); chm and trees fill only "
             "the data's footprint, the cells within 2 m (or 3 point spacings) of a return, and "
             "leave nodata beyond it; none = leave nodata",
             flag="-fill", choices=("mean8", "none"), default="mean8")
CO = Param("creation_options", "kv", "GDAL creation option KEY=VALUE for GeoTIFF outputs "
           "(repeatable)", flag="-co", advanced=True)
OVERWRITE = Param("overwrite", "bool", "Replace existing outputs", flag="-overwrite",
                  aliases=("--overwrite",), default=False)
READ = (A_SRS, T_SRS, DELIM, DECIMAL_COMMA, COLUMNS, SKIP_INVALID)
ALLOW_NO_CRS = Param("allow_no_crs", "bool", "Write outputs without a CRS when the input has "
                     "none (default: refused; give -a_srs)", flag="--allow-no-crs", default=False,
                     advanced=True)
READ_GEO = (*READ, ALLOW_NO_CRS)
KP_PARAMS = (
    Param("g", "float", "Kraus & Pfeifer g: residuals at or below g get weight 1", flag="-g",
          default=-2.0, unit="m"),
    Param("w", "float", "Kraus & Pfeifer w: residuals above g + w get weight 0", flag="-w",
          default=2.5, unit="m"),
    Param("a", "float", "Weight function a", flag="-a", default=1.0, advanced=True),
    Param("b", "float", "Weight function b", flag="-b", default=4.0, advanced=True),
    Param("iterations", "float", "Iterations per level", flag="-iterations", default=5,
          advanced=True),
    Param("cell", "float", "Cell of the finest filter surface", flag="-cell", default=1.5,
          advanced=True, unit="m"),
    Param("levels", "float", "Hierarchy levels (cell x 2^(levels-1) down to cell); 1 = plain "
          "filter", flag="-levels", default=5, advanced=True),
    Param("w_growth", "float", "At coarser levels w grows by this much per metre of cell "
          "(w + k (c - cell)) so coarse surfaces keep hilltops and crests", flag="-w_growth",
          default=0.2, advanced=True),
    Param("refine", "float", "Densification passes against the TIN of the ground points (stops "
          "when nothing changes); 0 = the plain robust-interpolation result", flag="-refine",
          default=10, advanced=True),
    Param("tolerance", "float", "Tolerance above the surface (FUSION /tolerance): when "
          "refining, a point is ground when -(1 + slope S) <= residual <= tolerance + slope S "
          "(S the TIN's slope; default 0.3 m); without refining, ground = residual <= "
          "tolerance when given, else residual <= g + w", flag="-tolerance", advanced=True,
          unit="m"),
    Param("slope", "float", "Tolerance added per unit of terrain slope (m/m) when refining",
          flag="-slope", default=1.25, advanced=True),
    Param("tin_cell", "float", "When refining, the TIN is built from the lowest ground point per "
          "cell of this size (keeps it out of shrubs); 0 = every ground point", flag="-tin_cell",
          default=1.5, advanced=True, unit="m"),
    Param("low", "float", "Leave out of the surfaces points this far below the second lowest of "
          "their 10 nearest neighbours (multipath); 0 = off", flag="-low", default=2.0,
          advanced=True, unit="m"),
    Param("gshift", "bool", "Shift g automatically each iteration from the residual histogram "
          "(Kraus & Pfeifer)", flag="-gshift", default=False, advanced=True),
)
CHM_RES = Param("res", "res", "Cell size of the CHM built from points, m, or auto = "
                "max(sqrt(1/n), 0.25) from the point density n, rounded to 0.05 m", flag="-tr",
                aliases=("--resolution",), default="auto", unit="m")
DROP_CLASS = Param("drop_class", "str", "Leave out points of these LAS classes (comma list; "
                   "default 7,18 = low and high noise; none keeps all)", flag="-drop_class",
                   default="7,18", advanced=True)
KEEP_CLASS = Param("keep_class", "str", "Use only points of these LAS classes (comma list, e.g. "
                   "1,2,3,4,5)", flag="-keep_class", advanced=True)
CLASSES = (DROP_CLASS, KEEP_CLASS)
TILES = (
    Param("tile_size", "str", "Process in square tiles of this side (m), each with a buffer "
          "(a single file is processed as a catalog of one); auto (default) = one tile for an "
          "area of at most 1 M points and 1 km across, else a side of about 500,000 points (250 "
          "m in dense data, up to 1000 m in sparse data); none = one tile", flag="-tile_size",
          advanced=True, unit="m"),
    Param("buffer", "float", "Buffer around each tile (default: trees 8 crown scales, at least "
          "20 m; chm 20 m; grid none, 20 m with -fill mean8)", flag="-buffer", advanced=True,
          unit="m"),
    Param("workers", "float", "Worker processes of the local Dask cluster (default: all cores, "
          "or this process below 1 M points, where starting a cluster costs more than it "
          "saves; 1 = in this process)", flag="-workers", advanced=True),
    Param("scheduler", "str", "Address of an existing Dask scheduler to run the tiles on, e.g. "
          "tcp://10.0.0.5:8786 (the workers must read the inputs at the same absolute paths)",
          flag="--scheduler", advanced=True),
    Param("on_error", "choice", "A tile that fails (twice on Dask): stop = stop the run, no "
          "output written; skip = write the other tiles' results, then fail naming the tiles "
          "left out", flag="-on_error", choices=("stop", "skip"), default="stop", advanced=True),
    Param("resume", "bool", "Continue a killed or failed run of several tiles from the tiles it "
          "kept beside its output (same command and inputs)", flag="-resume", default=False,
          advanced=True),
)
DTM_AUTO = Param("dtm", "str", "DTM: auto = class-2 ground points if the file has them, else "
                 "lowest:5; ground = class-2 points interpolated (TIN); lowest:R = lowest point "
                 "per R m cell, interpolated; kp or kp:G:W = Kraus & Pfeifer ground filter "
                 "(Leite et al.); min = lowest point per cell (Castro 2006; only where every cell "
                 "holds ground returns); none = heights already normalised; or a DTM GeoTIFF path",
                 flag="-dtm", default="auto")
CHM_KIND = Param("chm", "choice", "CHM from points: pitfree = pit-free CHM of the first returns "
                 "(Khosravipour et al. 2014); max = highest point per cell, gaps filled "
                 "(Castro 2006); tin = one TIN of the first returns", flag="-chm",
                 choices=("pitfree", "max", "tin"), default="pitfree")
KEEP_OUTLIERS = Param("keep_outliers", "bool", "Keep isolated returns far above the canopy "
                      "(birds, clouds, unclassified noise), which are removed by default",
                      flag="-keep_outliers", default=False, advanced=True)

PLOT_PARAMS = (
    Param("plots", "vector", "Field plots (parcelas): a polygon layer, or plot centres (points) "
          "with -plot_radius, PATH or PATH:LAYER", flag="-plots"),
    Param("plot_id", "field", "The plots' id field (default: the first of plot_id, parcela, "
          "id_parcela, plot, id, name present; else 1, 2, ...)", flag="-plot_id",
          advanced=True, parent="plots"),
    Param("plot_radius", "float", "Radius of circular plots given by their centres (11.28 m "
          "for 400 m²)", flag="-plot_radius", unit="m"),
)
METRIC_PARAMS = (
    Param("min_height", "str", "Metrics of the returns above this height (m); none = of every "
          "return (lidR's pixel_metrics default); cover counts the first returns above it",
          flag="-min_height", default="2"),
    Param("returns", "choice", "Metrics of all returns or of the first returns",
          flag="-returns", choices=("all", "first"), default="all"),
    Param("dtm", "str", "Ground for the heights (see chm); none = heights already normalised",
          flag="-dtm", default="auto", advanced=True),
)

COMMANDS = {
    "info": Command(
        "info", "Points", "Points, bounds, density, CRS, classes and returns of a point file",
        (INPUT, *READ, Param("json", "bool", "Print JSON", flag="--json", default=False)), "info"),
    "grid": Command(
        "grid", "Rasters", "Grid points into a GeoTIFF with one statistic per cell",
        (INPUT, Param("output", "output", "Output GeoTIFF"), RES,
         Param("stat", "choice", "Per-cell statistic of z", flag="-stat",
               choices=("max", "min", "mean", "count"), default="max"),
         Param("fill", "choice", FILL.help, flag="-fill", choices=("mean8", "none"), default="none"),
         *CLASSES, *TILES, *READ_GEO, CO, OVERWRITE), "grid", outputs=("output",)),
    "chm": Command(
        "chm", "Rasters", "Canopy height model CHM = DSM (highest point per cell) - DTM",
        (INPUT, Param("output", "output", "Output CHM GeoTIFF"), CHM_RES, DTM_AUTO, CHM_KIND,
         FILL, *CLASSES, KEEP_OUTLIERS, *TILES,
         Param("dsm_out", "output", "Also write the DSM here", flag="-dsm_out", advanced=True),
         Param("dtm_out", "output", "Also write the DTM here", flag="-dtm_out", advanced=True),
         *READ_GEO, CO, OVERWRITE), "chm", outputs=("output", "dsm_out", "dtm_out")),
    "trees": Command(
        "trees", "Trees", "Tree tops, crowns and a stand summary (GeoPackage) from points or a CHM",
        (Param("input", "input", "Point file (LAS/LAZ, XYZ) or a CHM GeoTIFF"),
         Param("output", "output", "Output GeoPackage (.gpkg)"),
         CHM_RES,
         Param("method", "choice", "Crowns: rg = region growing (Castro 2006 / Hyyppä 2001); "
               "treex = TreeX priority growing (Pantaleão et al.); watershed = Vincent-Soille on the "
               "inverted CHM (Castro 2006); mcws = marker-controlled watershed from the tops",
               flag="-method", choices=("rg", "treex", "watershed", "mcws"), default="rg"),
         Param("smooth", "str", "CHM filter: auto = a Gaussian sized from the crown scale "
               "(measured on the CHM, or from -spacing); none; gauss3 (Castro's fine mask); "
               "gauss5 (coarse mask); gauss:SIGMA (m); or OP:ELEMENT[:SIZE], OP in erode, "
               "dilate, open, close, abefec, fecabe, fecabefec, abefecabe; ELEMENT cross, "
               "square, rhombus. Default: auto, but none with -method treex or watershed "
               "(their papers work on the raw height model)", flag="-smooth", default=None),
         Param("min_height", "float", "Minimum tree height", flag="-min_height", default=2.0,
               unit="m"),
         Param("spacing", "str", "Plantation mode: planting spacing ROWSxTREES in m, e.g. 3x2, "
               "or auto (found under the tops, per stand with -stands); "
               "each empty planting position classified missing, suppressed or uncertain (gaps "
               "layer), and stocking, added to the output. Default: auto with -stands (a stand "
               "that shows no lattice keeps the defaults' trees); without, auto over the "
               "planted blocks between roads where the canopy shows planting rows",
               flag="-spacing"),
         Param("tops", "choice", "Tree tops: aw = adaptive window (crown scale x height); lm = "
               "8-neighbour maxima, one per plateau (Castro 2006); strict = strictly higher than "
               "all 8 neighbours, grid-border cells excluded (Castro's literal rule); treex = "
               "TreeX window; vwf = window "
               "0.1 h + 0.5 m; auto = treex for -method treex, aw with -smooth auto, else lm",
               flag="-tops", choices=("auto", "aw", "lm", "strict", "treex", "vwf"),
               default="auto", advanced=True),
         Param("crown_scale", "float", "Crown scale for -smooth auto and -tops aw (default: "
               "measured on the CHM)", flag="-crown_scale",
               advanced=True, unit="m"),
         Param("window_factor", "float", "Adaptive window radius for a tree of the dominant "
               "height, in crown scales", flag="-window_factor", default=0.9, advanced=True),
         Param("min_separation", "float", "Adaptive window: smallest distance between two tops "
               "(default 2.6 CHM cells, 1.3 m at 4 pts/m², at most 1.8 crown scales; with "
               "-spacing at least 0.6 x the smaller spacing; 0 = no limit)",
               flag="-min_separation", advanced=True, unit="m"),
         Param("planting", "choice", "Without -spacing: auto = with -stands, -spacing auto; "
               "without, when the tops lie on a planting "
               "lattice (at least 100 trees, lattice fit >= 0.25), look again at its empty "
               "positions for trees the tops finder missed (each tile with its buffer); none = "
               "off. Default: auto with the default method (rg, -smooth auto, -tops auto), none "
               "with a seed method or configuration, which then runs as its paper defines it",
               flag="-planting", choices=("auto", "none"), default=None, advanced=True),
         Param("step", "float", "Region-growing threshold step (ajuste, Castro 2006, Annex 2)",
               flag="-step", default=0.1, advanced=True, unit="m"),
         Param("mean_crown_area", "float", "TreeX window: mean crown area", flag="-mean_crown_area",
               default=6.0, advanced=True, unit="m²"),
         Param("sd_crown_area", "float", "TreeX window step: crown-area standard deviation",
               flag="-sd_crown_area", default=2.0, advanced=True, unit="m²"),
         Param("max_crown_area", "float", "TreeX maximum crown area", flag="-max_crown_area",
               default=16.0, advanced=True, unit="m²"),
         Param("min_crown_height", "float", "TreeX minimum crown height",
               flag="-min_crown_height", default=2.0, advanced=True, unit="m"),
         Param("connectivity", "choice", "TreeX growth neighbourhood", flag="-connectivity",
               choices=("4", "8"), default="4", advanced=True),
         Param("treex_centred", "bool", "TreeX: also require each top to be the highest of the "
               "window centred on it (drops one of two close trees; not in the seed)",
               flag="-treex_centred", default=False, advanced=True),
         Param("treex_local", "bool", "TreeX: also require each top to be a local maximum of its "
               "8 neighbours (drops crown-flank tops, and trees that lose every window to a "
               "taller neighbour; not in the seed)", flag="-treex_local", default=False,
               advanced=True),
         Param("dtm", "str", "DTM for points input (see chm); default auto = class-2 ground "
               "points if any, else lowest:5", flag="-dtm", default="auto", advanced=True),
         Param("chm", "choice", CHM_KIND.help, flag="-chm", choices=CHM_KIND.choices,
               default="pitfree", advanced=True),
         *CLASSES, KEEP_OUTLIERS, *TILES,
         Param("fill", "choice", FILL.help, flag="-fill", choices=("mean8", "none"),
               default="mean8", advanced=True),
         Param("nln", "str", "Prefix for the layer names (tree_tops, crowns, summary)",
               flag="-nln", advanced=True),
         Param("layer_options", "kv", "GeoPackage layer creation option KEY=VALUE; and for the "
               "-csv and -stand_csv tables " + TABLE_LCO, flag="-lco", advanced=True),
         Param("png", "output", "Also write a quick-look PNG (the CHM in height classes with a "
               "legend, crown outlines, tops, coordinates, scale bar, the summary as title)",
               flag="-png", advanced=True),
         Param("title", "str", "The quick look's title (default: the input's name and the "
               "summary)", flag="-title", advanced=True),
         Param("csv", "output", "Also write the trees as a table (.csv, or .xlsx): tree_id, "
               "stand_id, row_number, plant_number, x, y, height, crown_diameter, crown_area, "
               "suppressed, chm_row, chm_col", flag="-csv", advanced=True),
         Param("chm_out", "output", "Also write the CHM GeoTIFF", flag="-chm_out", advanced=True),
         Param("stands", "vector", "Stand (talhão) polygons, PATH or PATH:LAYER of any OGR "
               "polygon source (GeoPackage, shapefile): every tree, crown and gap gets its "
               "stand_id and a stands layer the per-stand inventory (trees/ha, mean and dominant "
               "height, crown diameter, canopy cover, height classes; with -spacing each stand's "
               "own lattice and stocking)", flag="-stands"),
         Param("stand_id", "field", "The stands' id field (default: the first of stand_id, "
               "talhao, id_talhao, cod_talhao, codigo, id, name, nome present; else 1, 2, ...)",
               flag="-stand_id", advanced=True, parent="stands"),
         Param("stand_csv", "output", "Also write the per-stand inventory as a table (.csv, or "
               ".xlsx), the stands' own attributes included",
               flag="-stand_csv", advanced=True),
         *READ_GEO, OVERWRITE,
         Param("append", "bool", "Append to an existing GeoPackage", flag="-append",
               default=False, advanced=True)), "trees",
        outputs=("output", "png", "csv", "chm_out", "stand_csv")),
    "compare": Command(
        "compare", "Trees", "Castro (2006) Table 1: ten smoothing/segmentation configurations compared",
        (Param("input", "input", "Point file (LAS/LAZ, XYZ) or a CHM GeoTIFF"),
         Param("output", "output", "Output CSV"),
         Param("res", "res", "CHM cell size, m (Castro 2006: 0.2 m, the laser footprint), or "
               "auto = max(sqrt(1/n), 0.25) from the point density n", flag="-tr",
               aliases=("--resolution",), default=0.2, unit="m"),
         Param("min_height", "float", "Minimum tree height", flag="-min_height", default=2.0,
               unit="m"),
         Param("step", "float", "Region-growing threshold step", flag="-step", default=0.1,
               advanced=True, unit="m"),
         Param("tops", "choice", "Tree tops: strict = strictly higher than all 8 neighbours, a "
               "flat top or a cell on the grid's border (which lacks neighbours) giving none "
               "(Castro's rule); lm = one top per plateau of 8-neighbour maxima (then region "
               "growing starts from the watershed's basins)", flag="-tops",
               choices=("strict", "lm"), default="strict"),
         Param("dtm", "str", "DTM for points input (see chm); auto = class-2 ground points if "
               "any, else lowest:5 (Castro's DTM holds only ground points; -dtm min, the lowest "
               "point per cell, is the canopy where a cell holds one return)", flag="-dtm",
               default="auto", advanced=True),
         Param("chm", "choice", CHM_KIND.help + " (here default max, Castro's surface)",
               flag="-chm", choices=CHM_KIND.choices, default="max"),
         *CLASSES,
         Param("fill", "choice", FILL.help, flag="-fill", choices=("mean8", "none"),
               default="mean8", advanced=True),
         *READ_GEO, OVERWRITE), "compare", outputs=("output",)),
    "ground": Command(
        "ground", "Ground", "Ground points by Kraus & Pfeifer hierarchical robust interpolation "
        "(Leite et al.) and TIN densification, classified LAS/LAZ and DTM",
        (Param("input", "input", INPUT.help + "; or a folder, glob or .vpc of point files "
               "(each file classified with a buffer of its neighbours' points)"),
         Param("output", "output", "Output classified LAS/LAZ (ground = class 2); for several "
               "input files, a folder that gets one classified file per input, same name"),
         Param("dtm_out", "output", "Also write the DTM GeoTIFF (linear TIN of the ground points; "
               "one seamless mosaic over every input file)", flag="-dtm_out", aliases=("-dtm",)),
         Param("res", "res", "DTM cell size, m, or auto = sqrt(1/n) (Leite et al.)", flag="-tr",
               aliases=("--resolution",), default="auto", unit="m"),
         *KP_PARAMS,
         Param("reclassify", "bool", "Also give the filter's decision to points of other classes "
               "(water, buildings...); by default only classes 0, 1, 2 change", flag="-reclassify",
               default=False, advanced=True),
         Param("buffer", "float", "Buffer of neighbouring files' points around each file (default "
               "30 m)", flag="-buffer", advanced=True, unit="m"),
         *(p for p in TILES if p.name in ("workers", "scheduler", "on_error")),
         *READ_GEO, CO, OVERWRITE), "ground", outputs=("output", "dtm_out")),
    "dtm-quality": Command(
        "dtm-quality", "Ground", "DTM quality sweep (Leite et al.): Kraus & Pfeifer (g, w) grid, "
        "GLCM texture, PCA, k-means",
        (Param("input", "input", INPUT.help + "; or a folder, glob or .vpc of point files (each "
               "file filtered with a buffer of its neighbours' points, one DTM over all)"),
         Param("outdir", "outdir", "Output folder (CSV, hillshade PNGs, recommended_dtm.tif). "
               "The CSV ranks the DTMs (1 = most trusted) with a role and why: good (smooth "
               "texture, agreeing with the sweep's median DTM), noisy, outlier (smooth but far "
               "from that median), incomplete (under 1 ground point per 10 m², or not covering "
               "the data)", required=True),
         Param("g", "str", "g values START:STOP:STEP (Leite et al.: -4:1:0.5)", flag="-g",
               default="-4:1:0.5"),
         Param("w", "str", "w values START:STOP:STEP (Leite et al.: 1:4:0.5)", flag="-w",
               default="1:4:0.5"),
         Param("res", "res", "DTM cell size, m, or auto = sqrt(1/n) (Leite et al.)", flag="-tr",
               aliases=("--resolution",), default="auto", unit="m"),
         Param("reference_dtm", "str", "Reference ground to check each DTM against: a DTM "
               "GeoTIFF, auto = the file's class-2 points (the vendor's ground) when it has "
               "any, or none. With a reference, the recommended DTM is the complete one "
               "closest to it (the texture's choice is reported beside)",
               flag="-reference_dtm", aliases=("-reference",),
               default="auto"),
         *[p for p in KP_PARAMS if p.name not in ("g", "w", "tolerance", "refine")],
         Param("refine", "float", "Densification passes after the robust interpolation; 0 (Leite "
               "et al.'s filter) makes the DTM depend on g and w, with passes most (g, w) give "
               "one DTM", flag="-refine", default=0, advanced=True),
         Param("seed", "float", "k-means random seed", flag="-seed", default=0, advanced=True),
         *READ_GEO, OVERWRITE), "dtm_quality"),
    "stem": Command(
        "stem", "Terrestrial", "Trunk points, DBH and taper of one tree by the Dmax filter "
        "(Buck et al. 2014)",
        (Param("input", "input", "One tree's TLS points (LAS/LAZ or XYZ)"),
         Param("prefix", "outdir", "Output prefix: PREFIX_trunk.laz, _sections.csv/.gpkg, "
               "_summary.json, _taper.png", required=True),
         Param("section", "float", "Section thickness", flag="-section", default=0.05, unit="m"),
         Param("search", "float", "Half-size of the square search region around the stem",
               flag="-search", default=0.5, unit="m"),
         Param("hspacing", "float", "Horizontal point spacing of the scan (sets the search-point "
               "step)", flag="-hspacing", default=0.005, advanced=True, unit="m"),
         Param("vspacing", "float", "Vertical point spacing of the scan: a complete section holds "
               "2 pi r / hspacing x section / vspacing points (expected_points, completeness "
               "in the sections CSV); -section must be at least this", flag="-vspacing",
               default=0.010, advanced=True, unit="m"),
         Param("base", "str", "Base height: auto (local ground) or a z value", flag="-base",
               default="auto", advanced=True),
         Param("start", "float", "First section this far above the base", flag="-start",
               default=0.5, advanced=True, unit="m"),
         *READ_GEO, OVERWRITE), "stem"),
    "profile": Command(
        "profile", "Terrestrial", "Roots / stem / canopy from the point-density profile "
        "(Queiroz 2017)",
        (Param("input", "input", "One tree's TLS points (LAS/LAZ or XYZ)"),
         Param("output", "output", "Output LAS/LAZ with the extra dimension part (1 roots, 2 "
               "stem, 3 canopy); boundaries JSON/CSV and a PNG beside it"),
         Param("bin", "float", "Slice height", flag="-bin", default=0.05, unit="m"),
         Param("sigma", "float", "Gaussian smoothing sigma (0.1, 0.3, 0.6 tested; 0.3 best)",
               flag="-sigma", default=0.3, unit="m"),
         Param("rule", "choice", "Boundaries: spread = stem start at the density profile's "
               "first concave-to-convex inflection, canopy start where the horizontal spread "
               "leaves the stem's (3x and 0.25 m more, over a metre); queiroz = Queiroz's "
               "ordinal rule, the 1st, 2nd and 3rd inflections are tree, stem and canopy start",
               flag="-rule", choices=("spread", "queiroz"), default="spread"),
         *READ_GEO, OVERWRITE), "profile", outputs=("output",)),
    "evaluate": Command(
        "evaluate", "Trees", "Accuracy of tree tops against reference trees (Eysn et al. 2015 "
        "matching): recall, precision, F, height bias and RMSE",
        (Param("detected", "input", "Detected trees: a GeoPackage from trees (layer tree_tops) or "
               "a CSV with x, y, height"),
         Param("reference", "input", "Reference trees: CSV with x, y and optionally height, or "
               "a vector file of points"),
         Param("report", "output", "Also write the report (.json) or the matched pairs (.csv)",
               flag="-o"),
         Param("max_dist", "float", "Largest horizontal distance of a match", flag="-max_dist",
               default=2.5, unit="m"),
         Param("max_dz", "float", "Largest height difference of a match", flag="-max_dz",
               default=5.0, unit="m"),
         Param("layer", "str", "Layer of the detected file (default: the tree_tops layer)",
               flag="-layer", advanced=True),
         Param("ref_layer", "str", "Layer of the reference file (default: the first)",
               flag="-ref_layer", advanced=True),
         Param("area", "str", "Where the reference was measured: xmin,ymin,xmax,ymax or a "
               "polygon file (PATH or PATH:LAYER); detections outside it are not false "
               "positives, references outside it are left out", flag="-area"),
         Param("layer_options", "kv", TABLE_LCO, flag="-lco", advanced=True),
         OVERWRITE), "evaluate", outputs=("report",)),
    "metrics": Command(
        "metrics", "Inventory", "Standard height metrics (lidR .stdmetrics_z, FUSION L-moments "
        "and cover) per cell (multi-band GeoTIFF) or per field plot and stand (GeoPackage)",
        (INPUT, Param("output", "output", "Output: a .tif gets one named band a metric per "
                      "cell; a .gpkg the layers plot_metrics and stand_metrics"),
         Param("res", "float", "Metric cell size (use the plots' size for an area-based "
               "model: 20 m for 400 m² plots)", flag="-tr", aliases=("--resolution",),
               default=20.0, unit="m"),
         *PLOT_PARAMS,
         Param("stands", "vector", "Stand (talhão) polygons, PATH or PATH:LAYER", flag="-stands"),
         Param("stand_id", "field", "The stands' id field (default: stand_id, talhao, ... or "
               "numbered)", flag="-stand_id", advanced=True, parent="stands"),
         *METRIC_PARAMS,
         *CLASSES, *(p for p in TILES if p.name in ("tile_size", "workers", "scheduler")),
         *READ_GEO, CO, OVERWRITE), "metrics", outputs=("output",)),
    "volume": Command(
        "volume", "Inventory", "Wood volume per stand (m³/ha, m³, basal area) with 95 % "
        "intervals, from LiDAR and field plots: area-based model and/or detected trees",
        (INPUT, Param("plots", "vector", "Field plots (parcelas): a polygon layer, or plot "
                      "centres (points) with -plot_radius; may carry volume_m3_ha when there "
                      "is no tree table", required=True),
         Param("output", "output", "Output GeoPackage (layers plots, stands, tree_tops); "
               "OUT_volume.tif (m³/ha), OUT_report.json and OUT_report.png beside it"),
         Param("stands", "vector", "Stand (talhão) polygons, PATH or PATH:LAYER",
               flag="-stands", required=True),
         Param("trees_table", "table", "Field trees table (CSV/TXT, pt-BR or English): plot "
               "(parcela), tree (arvore), DAP cm (dap) or CAP cm (cap), HT m (ht, for all or "
               "some trees), volume m³ (optional); .xlsx read too", flag="-trees_table"),
         *(p for p in PLOT_PARAMS if p.name != "plots"),
         Param("volume_field", "field", "The plots' volume field (m³/ha) when there is no tree "
               "table (default: the first of volume_m3_ha, vol_ha, vtcc_ha, volume, vol)",
               flag="-volume_field", advanced=True, parent="plots"),
         Param("stand_id", "field", "The stands' id field (default: stand_id, talhao, ... or "
               "numbered)", flag="-stand_id", advanced=True, parent="stands"),
         Param("volume_equation", "str", "Schumacher-Hall coefficients b0,b1,b2 of V = "
               "b0·DAP^b1·HT^b2 (DAP cm, HT m, V m³), or ff:F for a form factor F (V = "
               "F·g·HT, g = π·DAP²/40000); default: fitted on the trees that carry a volume",
               flag="-volume_equation"),
         Param("approach", "choice", "aba = area-based model of the plots' height metrics; "
               "trees = detected trees' volume from their heights, scaled by the plots; both",
               flag="-approach", choices=("aba", "trees", "both"), default="aba"),
         Param("res", "str", "Cell size of the wall-to-wall metrics: auto = the plots' size "
               "(20 m for 400 m² plots)", flag="-tr", aliases=("--resolution",),
               default="auto", unit="m"),
         Param("resamples", "float", "Bootstrap resamples of the plots for the intervals",
               flag="-resamples", default=400, advanced=True),
         Param("estimator", "choice", "A stand's figure: eblup = the model's, corrected by "
               "the stand's own plots as far as they can be trusted; model = the model's alone",
               flag="-estimator", choices=("eblup", "model"), default="eblup", advanced=True),
         Param("stand_csv", "output", "Also write the per-stand figures as a table (.csv, or "
               ".xlsx), the stands' own attributes included", flag="-stand_csv",
               advanced=True),
         Param("layer_options", "kv", "GeoPackage layer creation option KEY=VALUE; and for "
               "the -stand_csv table " + TABLE_LCO, flag="-lco", advanced=True),
         *METRIC_PARAMS, *CLASSES,
         *(p for p in TILES if p.name in ("tile_size", "workers", "scheduler")),
         *READ_GEO, CO, OVERWRITE), "volume", outputs=("output", "stand_csv"),
        files=(("raster", "raster", "Volume raster (m³/ha)"),
               ("json", "file", "Model report (JSON)"),
               ("png", "file", "Measured against predicted (PNG)"))),
    "demo": Command(
        "demo", "Demo", "Generate a synthetic eucalyptus stand with known trees and process it",
        (Param("outdir", "outdir", "Output folder (default lidartrees_demo)", default=None,
               required=False), OVERWRITE), "demo"),
}


def command_args(cmd: Command, kw: dict) -> list:
    """``lidartrees`` arguments equivalent to running ``cmd`` with ``kw``: positional parameters
    first, then the options whose value differs from their default."""
    args = [cmd.name]
    for p in cmd.params:
        v = kw.get(p.name)
        if p.positional:
            if v is not None:
                args.append(str(v))
            continue
        if v is None or v is False or v == "" or v == [] or (v == p.default and p.kind != "res"):
            continue
        if p.kind == "bool":
            args.append(p.flag)
        elif p.kind == "kv":
            for item in v:
                args += [p.flag, str(item)]
        else:
            args += [p.flag, str(v)]
    return args


def command_line(cmd: Command, kw: dict) -> str:
    """The shell command line of :func:`command_args` (as QGIS's GDAL tools show it)."""
    import shlex

    return " ".join(["lidartrees"] + [shlex.quote(a) for a in command_args(cmd, kw)])

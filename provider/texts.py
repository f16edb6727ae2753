"""The provider's user-facing texts, in English, and the list of them a translation covers.

No QGIS import here: ``scripts/i18n.py`` reads :func:`source_strings` with any Python to
update ``provider/i18n/lidartrees_*.ts``. At run time each text goes through :func:`tr`
(``QCoreApplication.translate('LidarTrees', text)``), which returns it unchanged when no
translation is installed (see ``provider/i18n.py``).
"""
from ._lib import commands

CONTEXT = "LidarTrees"

INPUT_FILTER_PARTS = ("Point clouds and rasters", "Tree tables", "All files")
CASTRO = ("Castro, F. da C. e (2006). Segmentação de imagens geradas por laser scanning "
          "aerotransportado para delimitação de árvores individuais em áreas de reflorestamento de "
          "eucaliptos. MSc dissertation, Universidade Tecnológica Federal do Paraná (UTFPR), "
          "Curitiba")
KHOSRAVIPOUR = ("Khosravipour, A., Skidmore, A. K., Isenburg, M., Wang, T. & Hussin, Y. A. (2014). "
                "Generating pit-free canopy height models from airborne lidar. PE&RS 80(9), 863-872")
#: what each algorithm's help cites (the citations themselves stay as published)
REFERENCES = {
    "chm": ("{castro}, §2.3: DSM = highest point per cell, DTM = lowest, gap filling by the mean "
            "of the 8 neighbours (-chm max). {khosravipour} (-chm pitfree, the default). "
            "Leite et al.: C = sqrt(1/n)."),
    "grid": "{castro}, §2.3.",
    "trees": ("{castro}: Gaussian masks, grey morphology (abefec...), region growing after Hyyppä "
              "et al. (2001) (Annex 2), Vincent & Soille (1991) watershed (Annex 1). Pantaleão, "
              "Dutra & Macedo, TreeX: moving window + priority growing. "
              "{khosravipour}. Eysn, L. et al. (2015), Forests 6, 1721-1747 (evaluation)."),
    "compare": "{castro}, Table 1.",
    "evaluate": ("Eysn, L. et al. (2015). A benchmark of lidar-based single tree detection "
                 "methods using heterogeneous forest data from the Alpine Space. Forests 6, "
                 "1721-1747."),
    "ground": ("Kraus, K. & Pfeifer, N. (1998) robust interpolation, as in FUSION's GroundFilter, "
               "hierarchical after Pfeifer, N. et al. (2001), then densification against a TIN "
               "of the ground; (g, w) for eucalyptus by Leite et al.."),
    "dtm-quality": "Leite et al.: 77 (g, w) DTMs judged by GLCM texture, PCA and k-means.",
    "stem": "Buck, A. L. B. et al. (2014), Dmax filter for trunk points of Pinus in TLS clouds.",
    "profile": ("Queiroz (2017), vertical segmentation of mangrove trees into roots, stem and "
                "canopy from the point-density profile."),
    "metrics": "lidR's stdmetrics_z (Roussel, J.-R. et al. (2020), lidR, Remote Sensing of "
               "Environment 251, 112061); FUSION's L-moments and cover (McGaughey, R. J., "
               "FUSION/LDV manual). Definitions: docs/VOLUME.md.",
    "volume": "Area-based approach (Næsset, E. (2002), Remote Sensing of Environment 80, "
              "88-99); Schumacher, F. X. & Hall, F. S. (1933) volume equation; eucalyptus "
              "plantations: Silva, C. A. et al. (2016), Forestry. Model form, intervals and "
              "limits: docs/VOLUME.md.",
}

#: readable labels for parameters whose help text is too long to be one
LABELS = {
    "stands": "Stands (talhões) polygon layer", "stand_id": "Stand id field",
    "plot_id": "Plot id field", "trees_table": "Field trees table",
    "stand_csv": "Per-stand inventory CSV",
    "a_srs": "CRS of the input (assign)", "t_srs": "Reproject to CRS",
    "allow_no_crs": "Allow outputs without a CRS", "buffer": "Tile buffer",
    "chm": "Canopy height model", "columns": "Text columns (x,y,z,...)",
    "creation_options": "GeoTIFF creation options", "crown_scale": "Crown scale",
    "delimiter": "Text delimiter", "detected": "Detected tree tops",
    "drop_class": "Leave out LAS classes", "dtm": "Terrain model (DTM)",
    "dtm_out": "Terrain model output", "fill": "Gap filling", "gshift": "Shift g automatically",
    "hspacing": "Horizontal search spacing", "input": "Input", "keep_class": "Use only LAS classes",
    "keep_outliers": "Keep points far above the canopy", "levels": "Filter levels",
    "low": "Low-point depth", "method": "Crown segmentation", "output": "Output",
    "prefix": "Output prefix", "reclassify": "Reclassify other classes too",
    "reference": "Reference trees", "refine": "Densification passes",
    "reference_dtm": "Reference ground (DTM GeoTIFF; auto = class-2 points; none)",
    "rule": "Boundary rule", "area": "Reference area (xmin,ymin,xmax,ymax or polygons)",
    "res": "Cell size", "scheduler": "Dask scheduler address",
    "skip_invalid": "Skip malformed text lines", "slope": "Slope tolerance factor",
    "smooth": "Smoothing", "spacing": "Planting spacing (rows x trees)",
    "strict": "Strict local maxima", "tile_size": "Tile size", "tin_cell": "TIN vertex cell",
    "tolerance": "Tolerance above the surface", "tops": "Tree-top rule",
    "treex_centred": "TreeX: also highest of the centred window",
    "treex_local": "TreeX: also a local maximum of 8 neighbours", "w_growth": "w growth per level",
    "window_factor": "Window factor", "workers": "Workers",
    "min_separation": "Smallest distance between tops",
    "planting": "Planting lattice under the tops (without spacing)",
    "png": "Quick-look PNG", "csv": "Trees CSV", "title": "Quick-look title",
    "outdir": "Output folder", "lco": "Layer options",
    "vspacing": "Vertical scan spacing", "base": "Base height", "on_error": "When a tile fails",
    "resume": "Resume a killed run", "step": "Region-growing step",
}

#: fixed texts of the algorithms (parameters, outputs, help headings, messages); messages with
#: a value take it through str.format, so the translation keeps the {placeholders}
UI = (
    "…or a point-cloud layer loaded in QGIS", "Information (JSON)", "Number of points",
    "Number of trees", "Cell size (m), or auto", "Reference:", "Command line:",
    "GeoPackage (*.gpkg)", "JSON report (*.json)", "Matched pairs CSV (*.csv)",
    "cancelled: no output written",
    "Give the input: a point file (Input), or a point-cloud layer loaded in QGIS",
    "The point-cloud layer '{name}' is not a local file ({src}); export it to LAS/LAZ first",
    "Unknown parameter(s) {unknown} for {alg}; its parameters are {known}",
    "{pid}: cannot save the layer '{name}' for the command ({error})",
    "LiDAR Trees: the 'lidartrees' command was not found. Install the lidartrees_gis package "
    "from its source folder (the one holding pyproject.toml) or its wheel "
    "(lidartrees_gis-*.whl) in its own environment (python3 -m venv ~/.venvs/lidartrees && "
    "~/.venvs/lidartrees/bin/pip install /path/to/lidartrees_gis; it is not published on PyPI) "
    "and, if it is not on the PATH, set the environment variable LIDARTREES_EXE or the QGIS "
    "setting '{setting}' to its path.",
    "LiDAR Trees: '{exe} --version' failed: {error}",
    "LiDAR Trees: cannot run {exe}: {error}",
)


def tr(text: str) -> str:
    """``text`` in the language of the installed translator (unchanged without one or outside
    QGIS)."""
    try:
        from qgis.PyQt.QtCore import QCoreApplication
    except ImportError:
        return text
    return QCoreApplication.translate(CONTEXT, text)


def reference(name: str) -> str | None:
    """The citation text of algorithm ``name`` (translated around the citations), or None."""
    if name not in REFERENCES:
        return None
    return tr(REFERENCES[name]).format(castro=CASTRO, khosravipour=KHOSRAVIPOUR)


def english_label(p) -> str:
    """A parameter's label in English, without its unit: from :data:`LABELS`, else its help's
    first clause when short, else its name."""
    if p.name in LABELS:
        return LABELS[p.name]
    return p.help.split(";")[0].split(" (")[0].rstrip(".") if len(p.help) < 60 else (
        p.name.replace("_", " ").capitalize())


def label(p) -> str:
    """A parameter's label as QGIS shows it: translated, with its unit."""
    return tr(english_label(p)) + (f" ({p.unit})" if p.unit else "")


def source_strings() -> list:
    """Every text the provider passes through :func:`tr`, each once, in a stable order."""
    out = ["LiDAR Trees (lidartrees_gis)", *INPUT_FILTER_PARTS, *UI]
    for cmd in commands().values():
        out += [cmd.group, cmd.summary]
        for p in cmd.params:
            if p.name != "json":
                out += [english_label(p), p.help]
        out += [text for _, _, text in cmd.files]
    out += list(REFERENCES.values())
    seen, uniq = set(), []
    for s in out:
        if s not in seen:
            seen.add(s)
            uniq.append(s)
    return uniq

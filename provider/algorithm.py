"""One generic processing algorithm per ``lidartrees`` command.

Parameters are built from the command's :class:`lidartrees_gis.cli.commands.Param` list, so the
toolbox and the CLI share names, defaults, choices and help (parameter ids are the upper-case
names). The algorithm turns the values into ``lidartrees`` arguments and runs the CLI in a
subprocess (see ``_lib``): progress comes back as ``PROGRESS`` lines, a cancel terminates the
process (which removes its temporary outputs), and the CLI's error line becomes a
QgsProcessingException. It holds no algorithm code. Adding a command to
``lidartrees_gis.cli.commands.COMMANDS`` adds its algorithm here.
"""
import json
import os
import queue
import subprocess
import tempfile
import threading

from qgis.core import (QgsProcessingAlgorithm, QgsProcessingContext,
                       QgsProcessingException, QgsProcessingLayerPostProcessorInterface,
                       QgsProcessingOutputFile, QgsProcessingOutputNumber,
                       QgsProcessingOutputRasterLayer, QgsProcessingOutputString,
                       QgsProcessingParameterBoolean, QgsProcessingParameterCrs,
                       QgsProcessingParameterDefinition, QgsProcessingParameterEnum,
                       QgsProcessingParameterField, QgsProcessingParameterFile,
                       QgsProcessingParameterFileDestination,
                       QgsProcessingParameterFolderDestination, QgsProcessingParameterNumber,
                       QgsProcessingParameterPointCloudLayer,
                       QgsProcessingParameterRasterDestination, QgsProcessingParameterString,
                       QgsProcessingParameterVectorLayer, QgsProcessing)

from ._lib import commands, executable_error, find_executable, styles_dir
from .texts import INPUT_FILTER_PARTS, LABELS, REFERENCES, label, reference, tr  # noqa: F401

def input_filter() -> str:
    """The file dialog's filter for point and raster inputs, its labels translated."""
    pts, tables, every = (tr(t) for t in INPUT_FILTER_PARTS)
    return (f"{pts} (*.las *.laz *.xyz *.txt *.csv *.pts *.gz *.tif *.tiff);;"
            f"{tables} (*.gpkg *.csv *.shp);;{every} (*.*)")


def table_filter() -> str:
    """The file dialog's filter for a table of the user's (field trees): text or workbook."""
    _, tables, every = (tr(t) for t in INPUT_FILTER_PARTS)
    return f"{tables} (*.csv *.txt *.tsv *.xlsx);;{every} (*.*)"


#: style applied to each raster/vector output when loaded (command, parameter name) -> qml
STYLES = {("chm", "output"): "chm.qml", ("chm", "dtm_out"): "dtm_hillshade.qml",
          ("trees", "chm_out"): "chm.qml", ("grid", "output"): None}
#: commands whose INPUT can also be a point-cloud layer loaded in QGIS (INPUT_LAYER)
LAYER_INPUT = ("info", "grid", "chm", "trees", "compare", "ground", "dtm-quality", "stem",
               "profile", "metrics", "volume")
#: LAS/LAZ outputs (the default extension of a temporary output is the first one)
LAS_OUTPUTS = {("ground", "output"), ("profile", "output")}
GPKG_LAYERS = (("tree_tops", "tree_tops.qml"), ("crowns", "crowns.qml"))
GAPS_LAYER = ("gaps", "gaps.qml")  # plantation mode (-spacing, -stands, planted blocks)
STANDS_LAYER = ("stands", "stands.qml")  # with -stands, or the planted blocks
_KEEP = []  # post-processors must outlive processAlgorithm


class _Style(QgsProcessingLayerPostProcessorInterface):
    def __init__(self, qml):
        super().__init__()
        self.qml = qml

    def postProcessLayer(self, layer, context, feedback):  # noqa: N802
        if layer is not None and self.qml and os.path.exists(self.qml):
            layer.loadNamedStyle(self.qml)
            if os.path.basename(self.qml) == "chm.qml":
                fit_chm_classes(layer)
            layer.triggerRepaint()


def chm_ramp_items(limits, colours) -> list:
    """Discrete colour-ramp items for class upper ``limits`` (m), ``colours`` spread over them,
    labelled "lo - hi m" (also used by styles/make_styles.py to write chm.qml)."""
    from qgis.core import QgsColorRampShader

    n, lows = len(limits), [0.0] + list(limits[:-1])
    return [QgsColorRampShader.ColorRampItem(hi, _ramp_colour(colours, i / max(n - 1, 1)),
                                             f"{lo:g} - {hi:g} m")
            for i, (lo, hi) in enumerate(zip(lows, limits))]


def _ramp_colour(colours, t: float):
    """The colour at ``t`` (0-1) of the ramp through ``colours`` (QColor), linear in RGB: as
    many classes as the layer needs, each its own colour (picking the nearest anchor gave two
    classes the same colour when there were more classes than anchors)."""
    from qgis.PyQt.QtGui import QColor

    if len(colours) == 1:
        return QColor(colours[0])
    x = t * (len(colours) - 1)
    k = min(int(x), len(colours) - 2)
    f = x - k
    a, b = colours[k], colours[k + 1]
    return QColor(*(round(ca + (cb - ca) * f) for ca, cb in
                    ((a.red(), b.red()), (a.green(), b.green()), (a.blue(), b.blue()))))


def fit_chm_classes(layer, classes: int = 6) -> list:
    """Re-fit the CHM style's discrete classes to this layer's own range: about ``classes``
    classes of a round width (1, 2 or 5 m...) from 0 to the highest cell, in the style's
    colours. Returns the class upper limits."""
    import math

    from qgis.core import QgsRasterBandStats

    from lidartrees_gis.report.classes import height_classes

    rend = layer.renderer()
    shader = getattr(rend, "shader", lambda: None)()
    fn = shader.rasterShaderFunction() if shader is not None else None
    if fn is None or not hasattr(fn, "colorRampItemList"):
        return []
    colours = [it.color for it in fn.colorRampItemList()]
    top = layer.dataProvider().bandStatistics(1, QgsRasterBandStats.Max).maximumValue
    if not colours or not math.isfinite(top) or top <= 0:
        return []
    items = chm_ramp_items(height_classes(top, classes), colours)
    fn.setColorRampItemList(items)
    fn.setMinimumValue(0.0)
    fn.setMaximumValue(items[-1].value)
    rend.setClassificationMin(0.0)
    rend.setClassificationMax(items[-1].value)
    return [it.value for it in items]


def run_cli(args, feedback):
    """Run ``lidartrees ARGS --progress-lines`` and follow it: progress to ``feedback``, a cancel
    terminates it. Returns ``(exit code, last error line)``; -1 means cancelled."""
    exe = find_executable()
    proc = subprocess.Popen([exe, *args, "--progress-lines"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, bufsize=1)
    lines = queue.Queue()

    def pump(stream, tag):
        for line in stream:
            lines.put((tag, line.rstrip("\n")))
        lines.put((tag, None))

    threads = [threading.Thread(target=pump, args=(stream, tag), daemon=True)
               for stream, tag in ((proc.stdout, "out"), (proc.stderr, "err"))]
    for t in threads:
        t.start()
    open_streams, last_err, msg = 2, "", None
    while open_streams:
        if feedback.isCanceled() and proc.poll() is None:
            proc.terminate()
        try:
            tag, line = lines.get(timeout=0.1)
        except queue.Empty:
            continue
        if line is None:
            open_streams -= 1
        elif tag == "err" and line.startswith("PROGRESS "):
            parts = line.split(" ", 2)
            feedback.setProgress(float(parts[1]))
            if len(parts) > 2 and parts[2] and parts[2] != msg:
                msg = parts[2]
                feedback.setProgressText(msg)
        elif tag == "err":
            if line.strip():
                last_err = line.strip()
                if ": warning: " in line:  # the CLI's DataWarning lines, shown as warnings
                    feedback.pushWarning(line.strip())
                else:
                    feedback.pushConsoleInfo(line)
        else:
            feedback.pushConsoleInfo(line)
    rc = proc.wait()
    for t in threads:
        t.join()
    proc.stdout.close()  # the pipes are ours to close (ResourceWarning otherwise)
    proc.stderr.close()
    return (-1 if feedback.isCanceled() else rc), last_err


def qgis_message(cmd, msg: str) -> str:
    """A CLI error message in QGIS words: each option flag (``-tr``, ``-overwrite``) becomes the
    parameter's label in quotes."""
    import re

    flags = []
    for p in cmd.params:
        for f in ((p.flag,) if p.flag else ()) + tuple(p.aliases):
            flags.append((f, _label(p), p.kind != "bool"))
    # a flag followed by a value in the text ("-a_srs EPSG:29194", "-tr 0.5", "-a_srs 'SAD69
    # 24K'") reads "'label' = value"; a lower-case word after it is prose, not a value
    value = r"(?: ('[^']*'|[A-Z0-9][\w:./+-]*|auto|none)(?=[\s,;)]|$))?"
    for f, lab, takes in sorted(flags, key=lambda t: -len(t[0])):
        pat = rf"(?<![\w-]){re.escape(f)}(?![\w-])" + (value if takes else "")
        msg = re.sub(pat, lambda m, lab=lab: f"'{lab}'" + (f" = {m.group(1)}"
                                                        if m.lastindex and m.group(1) else ""),
                     msg)
    return msg


_label = label  # the name used before the texts moved to texts.py


def _output_kind(cmd_name, p):
    if p.kind == "outdir":
        return "folder"
    if (cmd_name, p.name) in LAS_OUTPUTS:
        return "las"
    if "png" in p.name:
        return "png"
    if cmd_name == "evaluate":
        return "json"
    if p.name in ("csv", "stand_csv") or cmd_name == "compare":
        return "csv"
    if cmd_name in ("trees", "volume") and p.name == "output":
        return "gpkg"
    return "raster"


def _layer_names(path) -> set:
    """The layers of a GeoPackage (none when it cannot be read)."""
    try:
        from osgeo import ogr

        ds = ogr.Open(str(path))
        return set() if ds is None else {ds.GetLayer(i).GetName()
                                         for i in range(ds.GetLayerCount())}
    except Exception:  # noqa: BLE001 - no layer list: the layers the parameters name
        return set()


def vector_source(layer, pid):
    """A polygon layer as the command line takes it: ``PATH`` or ``PATH:LAYER`` of its file;
    a layer with no file behind it (a memory or database layer) is saved to a temporary
    GeoPackage first."""
    if layer is None:
        return None
    if layer.providerType() == "ogr":
        parts = layer.source().split("|")
        path = parts[0]
        name = next((q.split("=", 1)[1] for q in parts[1:] if q.startswith("layername=")), "")
        if os.path.isfile(path) and not any(q.startswith(("subset=", "geometrytype="))
                                            for q in parts[1:]):
            return f"{path}:{name}" if name else path
    from qgis.core import QgsCoordinateTransformContext, QgsVectorFileWriter

    tmp = os.path.join(tempfile.mkdtemp(prefix="lidartrees-"), "stands.gpkg")
    opts = QgsVectorFileWriter.SaveVectorOptions()
    opts.driverName = "GPKG"
    err = QgsVectorFileWriter.writeAsVectorFormatV3(layer, tmp, QgsCoordinateTransformContext(),
                                                    opts)
    if err[0] != QgsVectorFileWriter.NoError:
        raise QgsProcessingException(tr("{pid}: cannot save the layer '{name}' for the command "
                                        "({error})").format(pid=pid, name=layer.name(),
                                                            error=err[1]))
    return tmp


class CommandAlgorithm(QgsProcessingAlgorithm):
    def __init__(self, command_name):
        super().__init__()
        self._name = command_name

    @property
    def cmd(self):
        return commands()[self._name]

    # -- identity --------------------------------------------------------------------------
    def name(self):
        return self._name

    def displayName(self):  # noqa: N802
        return f"{tr(self.cmd.summary)} ({self._name})"

    def group(self):
        return tr(self.cmd.group)

    def groupId(self):  # noqa: N802
        return self.cmd.group.lower()

    def shortHelpString(self):  # noqa: N802
        lines = [tr(self.cmd.summary) + ".", ""]
        for p in self.cmd.params:
            if p.name == "json":
                continue
            # the dialog's label first, the id processing.run takes after it; the help in the
            # dialog's words (each -flag of the text is the label of its parameter)
            lines.append(f"<b>{_label(p)}</b> ({p.name.upper()}): "
                         f"{qgis_message(self.cmd, tr(p.help))}")
        if self._name in REFERENCES:
            lines += ["", f"<i>{tr('Reference:')}</i> {reference(self._name)}"]
        lines += ["", f"{tr('Command line:')} lidartrees {self._name} --help"]
        return "<br>".join(lines)

    def createInstance(self):  # noqa: N802
        return CommandAlgorithm(self._name)

    def canExecute(self):  # noqa: N802
        err = executable_error()
        return (err is None, err or "")

    # -- parameters ------------------------------------------------------------------------
    def initAlgorithm(self, config=None):  # noqa: N802
        for p in self.cmd.params:
            if p.name == "json":
                continue
            d = self._make(p)
            if p.advanced:
                d.setFlags(d.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
            self.addParameter(d)
            if p.kind == "input" and self._name in LAYER_INPUT:
                self.addParameter(QgsProcessingParameterPointCloudLayer(
                    "INPUT_LAYER", tr("…or a point-cloud layer loaded in QGIS"), optional=True))
        if self._name == "info":
            self.addOutput(QgsProcessingOutputString("JSON", tr("Information (JSON)")))
            self.addOutput(QgsProcessingOutputNumber("POINTS", tr("Number of points")))
        if self._name == "trees":
            self.addOutput(QgsProcessingOutputNumber("TREES", tr("Number of trees")))
        for key, kind, text in self.cmd.files:  # files written beside the outputs
            cls = QgsProcessingOutputRasterLayer if kind == "raster" else QgsProcessingOutputFile
            self.addOutput(cls(key.upper(), tr(text)))

    def _make(self, p):
        pid, label = p.name.upper(), _label(p)
        optional = not (p.positional or p.required)
        if p.kind == "input":
            return QgsProcessingParameterFile(pid, label, QgsProcessingParameterFile.File,
                                              fileFilter=input_filter(),
                                              optional=self._name in LAYER_INPUT)
        if p.kind in ("output", "outdir"):
            kind = _output_kind(self._name, p)
            opt = not p.positional
            if kind == "folder":
                return QgsProcessingParameterFolderDestination(pid, label, optional=True)
            if kind == "raster":
                return QgsProcessingParameterRasterDestination(pid, label, optional=opt,
                                                               createByDefault=not opt)
            filt = {"gpkg": tr("GeoPackage (*.gpkg)"), "csv": "CSV (*.csv)", "png": "PNG (*.png)",
                    "las": "LAZ (*.laz);;LAS (*.las)",
                    "json": ";;".join((tr("JSON report (*.json)"),
                                       tr("Matched pairs CSV (*.csv)")))}[kind]
            return QgsProcessingParameterFileDestination(pid, label, filt, optional=opt,
                                                         createByDefault=not opt)
        if p.kind == "choice":
            return QgsProcessingParameterEnum(pid, label, options=list(p.choices),
                                              defaultValue=p.default, optional=optional,
                                              usesStaticStrings=True)
        if p.kind == "bool":
            return QgsProcessingParameterBoolean(pid, label, defaultValue=bool(p.default),
                                                 optional=True)
        if p.kind == "float":
            return QgsProcessingParameterNumber(pid, label, QgsProcessingParameterNumber.Double,
                                                defaultValue=p.default, optional=optional)
        if p.kind == "crs":
            return QgsProcessingParameterCrs(pid, label, optional=True)
        if p.kind == "vector":  # plots may be centres (points) with a radius
            types = [QgsProcessing.TypeVectorAnyGeometry if p.name == "plots"
                     else QgsProcessing.TypeVectorPolygon]
            return QgsProcessingParameterVectorLayer(pid, label, types, optional=optional)
        if p.kind == "res":
            return QgsProcessingParameterString(pid, tr("Cell size (m), or auto"),
                                                optional=not p.required)
        if p.kind == "field":  # picked from the parent layer's fields; typed when a path
            return QgsProcessingParameterField(pid, label, parentLayerParameterName=(
                p.parent.upper()), optional=True)
        if p.kind == "table":
            return QgsProcessingParameterFile(pid, label, QgsProcessingParameterFile.File,
                                              fileFilter=table_filter(), optional=optional)
        return QgsProcessingParameterString(pid, label, defaultValue=p.default, optional=True)

    def _value(self, p, parameters, context):
        pid = p.name.upper()
        if p.kind == "input":
            return self._input_path(parameters, pid, context)
        if pid not in parameters or parameters[pid] is None:
            return p.default if p.kind != "output" else None
        if p.kind in ("output", "outdir"):
            kind = _output_kind(self._name, p)
            if kind == "folder":
                folder = self.parameterAsString(parameters, pid, context) or None
                if folder and p.name == "prefix":  # the CLI takes a file prefix inside it
                    os.makedirs(folder, exist_ok=True)
                    base = os.path.splitext(os.path.basename(self._input_path(
                        parameters, "INPUT", context)))[0] or "tree"
                    return os.path.join(folder, base)
                return folder
            if kind == "raster":
                v = self.parameterAsOutputLayer(parameters, pid, context)
            else:
                v = self.parameterAsFileOutput(parameters, pid, context)
            return v or None
        if p.kind == "choice":
            return self.parameterAsEnumString(parameters, pid, context) or p.default
        if p.kind == "bool":
            v = self.parameterAsBoolean(parameters, pid, context)
            return True if v else (None if p.default is None else False)
        if p.kind == "float":
            return self.parameterAsDouble(parameters, pid, context)
        if p.kind == "crs":
            crs = self.parameterAsCrs(parameters, pid, context)
            if not crs.isValid():
                raw = parameters.get(pid)
                # a spelling QGIS does not know ('SAD69 24K'): the command reads it or says why
                return raw.strip() if isinstance(raw, str) and raw.strip() else None
            return crs.authid() or crs.toWkt()
        if p.kind == "vector":
            return vector_source(self.parameterAsVectorLayer(parameters, pid, context), pid)
        if p.kind == "field":
            names = self.parameterAsFields(parameters, pid, context)
            return names[0] if names and names[0] else p.default
        if p.kind == "table":
            return self.parameterAsFile(parameters, pid, context) or None
        if p.kind == "kv":
            s = self.parameterAsString(parameters, pid, context)
            return [t for t in s.replace(";", " ").split() if t] or None
        s = self.parameterAsString(parameters, pid, context)
        return s if s != "" else p.default

    def _input_path(self, parameters, pid, context):
        """The input file: INPUT, else the file behind the INPUT_LAYER point-cloud layer (its
        LAS/LAZ, or the ept.json index QGIS built, which chm and trees read)."""
        path = self.parameterAsFile(parameters, pid, context) if parameters.get(pid) else ""
        if path:
            return path
        layer = None
        if self._name in LAYER_INPUT and parameters.get("INPUT_LAYER") is not None:
            layer = self.parameterAsPointCloudLayer(parameters, "INPUT_LAYER", context)
            if layer is None and hasattr(parameters["INPUT_LAYER"], "source"):
                layer = parameters["INPUT_LAYER"]  # a layer object QGIS could not open itself
        if layer is None:
            raise QgsProcessingException(
                tr("Give the input: a point file (Input), or a point-cloud layer loaded in QGIS"))
        src = layer.source().split("|")[0]
        if not os.path.isfile(src):
            raise QgsProcessingException(
                tr("The point-cloud layer '{name}' is not a local file ({src}); export it to "
                   "LAS/LAZ first").format(name=layer.name(), src=src))
        return src

    # -- run -------------------------------------------------------------------------------
    def processAlgorithm(self, parameters, context, feedback):  # noqa: N802
        err = executable_error()
        if err:
            raise QgsProcessingException(err)
        from lidartrees_gis.cli.commands import command_args, command_line

        cmd = self.cmd
        known = {d.name() for d in self.parameterDefinitions()}
        unknown = sorted(k for k in parameters if k not in known)
        if unknown:
            raise QgsProcessingException(
                tr("Unknown parameter(s) {unknown} for {alg}; its parameters are {known}").format(
                    unknown=", ".join(unknown), alg=self.displayName(),
                    known=", ".join(sorted(known))))
        kw = {p.name: self._value(p, parameters, context) for p in cmd.params if p.name != "json"}
        feedback.pushCommandInfo(command_line(cmd, kw))
        fd, result_file = tempfile.mkstemp(prefix="lidartrees-", suffix=".json")
        os.close(fd)
        try:
            rc, last = run_cli(command_args(cmd, kw) + ["--result-json", result_file], feedback)
            if rc == -1:
                feedback.reportError(tr("cancelled: no output written"))
                return {}
            if rc != 0:
                raise QgsProcessingException(qgis_message(cmd, last.split("error: ", 1)[-1])
                                             or f"lidartrees exit {rc}")
            with open(result_file, encoding="utf-8") as fh:
                res = json.load(fh)
        finally:
            os.unlink(result_file)
        out = {}
        for p in cmd.params:
            if p.kind in ("output", "outdir") and kw.get(p.name):
                out[p.name.upper()] = kw[p.name]
                self._load_with_style(p, kw[p.name], context, with_gaps=bool(kw.get("spacing")),
                                      with_stands=bool(kw.get("stands")),
                                      prefix=kw.get("nln") or "",
                                      with_trees=kw.get("approach") in ("trees", "both"))
        if self._name == "info":
            out["JSON"] = json.dumps(res)
            out["POINTS"] = res["points"]
        if self._name == "trees":
            out["TREES"] = res["trees"]
        for key, _, _ in cmd.files:
            if res.get(key):
                out[key.upper()] = res[key]
        for k, v in res.items():
            if k not in ("table", "crs_wkt") and v not in (None, "") \
                    and not isinstance(v, (dict, list)):
                feedback.pushInfo(f"{k}: {v}")
        if "table" in res:
            feedback.pushInfo(res["table"])
        return out

    def _load_with_style(self, p, path, context, with_gaps=False, with_stands=False,
                         prefix="", with_trees=False):
        sdir = styles_dir()
        if self._name == "trees" and p.name == "output":
            # gaps and stands come with -spacing and -stands, and also with the defaults (each
            # stand's lattice; without stands, the planted blocks): the file says which
            present = _layer_names(path)
            extra = tuple(x for x, on in ((GAPS_LAYER, with_gaps), (STANDS_LAYER, with_stands))
                          if on or prefix + x[0] in present)
            for layer, qml in GPKG_LAYERS + extra:
                layer = prefix + layer
                uri = f"{path}|layername={layer}"
                details = QgsProcessingContext.LayerDetails(layer, context.project(), layer)
                if sdir:
                    post = _Style(os.path.join(sdir, qml))
                    _KEEP.append(post)
                    details.setPostProcessor(post)
                context.addLayerToLoadOnCompletion(uri, details)
            return
        if self._name == "volume" and p.name == "output":
            layers = (("stands", "volume_stands.qml"), ("plots", "volume_plots.qml")) + (
                (("tree_tops", "tree_tops.qml"),) if with_trees else ())
            for layer, qml in layers:
                details = QgsProcessingContext.LayerDetails(layer, context.project(), layer)
                if sdir and qml:
                    post = _Style(os.path.join(sdir, qml))
                    _KEEP.append(post)
                    details.setPostProcessor(post)
                context.addLayerToLoadOnCompletion(f"{path}|layername={layer}", details)
            raster = os.path.splitext(path)[0] + "_volume.tif"  # inventory.volume.side_outputs
            if os.path.exists(raster):
                details = QgsProcessingContext.LayerDetails("volume (m³/ha)", context.project(),
                                                            "volume")
                if sdir:
                    post = _Style(os.path.join(sdir, "volume.qml"))
                    _KEEP.append(post)
                    details.setPostProcessor(post)
                context.addLayerToLoadOnCompletion(raster, details)
            return
        if context.willLoadLayerOnCompletion(path):  # named after its file, not the label
            context.layerToLoadOnCompletionDetails(path).name = \
                os.path.splitext(os.path.basename(path))[0]
        qml = STYLES.get((self._name, p.name))
        if qml and sdir and context.willLoadLayerOnCompletion(path):
            post = _Style(os.path.join(sdir, qml))
            _KEEP.append(post)
            context.layerToLoadOnCompletionDetails(path).setPostProcessor(post)



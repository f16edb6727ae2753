"""Regenerate the QGIS styles in this folder with PyQGIS (QGIS >= 3.22):

    QT_QPA_PLATFORM=offscreen .venv-qgis/bin/python styles/make_styles.py

Layers are made in memory, styled with QGIS's own renderers and saved as .qml, so the files are
always valid for the QGIS version that wrote them.
"""
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
from qgis.core import (QgsApplication, QgsClassificationEqualInterval, QgsColorRampShader,  # noqa: E402
                       QgsFillSymbol, QgsGradientColorRamp, QgsGraduatedSymbolRenderer,
                       QgsHillshadeRenderer, QgsMarkerSymbol, QgsRasterLayer, QgsRasterShader,
                       QgsRendererRange, QgsSingleBandPseudoColorRenderer, QgsStyle,
                       QgsVectorLayer)
from qgis.PyQt.QtGui import QColor  # noqa: E402

HERE = Path(__file__).resolve().parent


def tiny_raster(path):
    import numpy as np
    import rasterio
    from rasterio.transform import from_origin

    with rasterio.open(path, "w", driver="GTiff", width=4, height=4, count=1, dtype="float32",
                       crs="EPSG:29194", transform=from_origin(0, 4, 1, 1)) as ds:
        ds.write(np.arange(16, dtype="float32").reshape(4, 4), 1)


def ramp(name):
    r = QgsStyle.defaultStyle().colorRamp(name)
    return r if r is not None else QgsGradientColorRamp(QColor("#f7fcb9"), QColor("#004529"))


#: CHM classes (m) and colours (ColorBrewer YlGn): light open ground to dark tall canopy. The
#: toolbox re-fits the class limits to each loaded CHM's own range (provider/algorithm.py).
CHM_COLOURS = ["#ffffe5", "#d9f0a3", "#addd8e", "#78c679", "#31a354", "#006837", "#004529"]


def chm_items(top: float, classes: int = 6):
    """Colour-ramp items: ``classes`` discrete classes of a round width from 0 to ``top``, by
    the rule the toolbox uses when it re-fits them to a loaded CHM."""
    sys.path.insert(0, str(HERE.parent))
    from provider.algorithm import chm_ramp_items

    from lidartrees_gis.report.classes import height_classes

    return chm_ramp_items(height_classes(top, classes), [QColor(c) for c in CHM_COLOURS])


def chm_style(path, out):
    lyr = QgsRasterLayer(str(path), "chm")
    shader = QgsRasterShader()
    fn = QgsColorRampShader(0.0, 30.0)
    fn.setColorRampType(QgsColorRampShader.Discrete)
    fn.setColorRampItemList(chm_items(30.0))
    shader.setRasterShaderFunction(fn)
    rend = QgsSingleBandPseudoColorRenderer(lyr.dataProvider(), 1, shader)
    rend.setClassificationMin(0.0)
    rend.setClassificationMax(30.0)
    lyr.setRenderer(rend)
    lyr.saveNamedStyle(str(out))


def dtm_style(path, out):
    """gdaldem hillshade's light (azimuth 315, altitude 45, z 1, one direction), on data
    resampled bilinearly before the shading (shading nearest-neighbour blocks draws stripes)."""
    from qgis.core import QgsRasterDataProvider, QgsRasterPipe

    lyr = QgsRasterLayer(str(path), "dtm")
    rend = QgsHillshadeRenderer(lyr.dataProvider(), 1, 315.0, 45.0)
    rend.setZFactor(1.0)
    rend.setMultiDirectional(False)
    lyr.setRenderer(rend)
    prov = lyr.dataProvider()
    prov.enableProviderResampling(True)
    prov.setZoomedInResamplingMethod(QgsRasterDataProvider.ResamplingMethod.Bilinear)
    prov.setZoomedOutResamplingMethod(QgsRasterDataProvider.ResamplingMethod.Bilinear)
    lyr.setResamplingStage(QgsRasterPipe.ResamplingStage.Provider)
    lyr.saveNamedStyle(str(out))


def graduated(layer, field, symbol_fn, breaks, colors):
    ranges = []
    for (lo, hi), col in zip(zip(breaks[:-1], breaks[1:]), colors):
        ranges.append(QgsRendererRange(lo, hi, symbol_fn(col), f"{lo:g} - {hi:g}"))
    rend = QgsGraduatedSymbolRenderer(field, ranges)
    rend.setClassificationMethod(QgsClassificationEqualInterval())
    layer.setRenderer(rend)


def label(lyr, expression: str, size: float, colour=None) -> None:
    """Label ``lyr`` with ``expression`` in ``size`` points (``colour``, QGIS's default else)
    on a white buffer."""
    from qgis.core import (QgsPalLayerSettings, QgsTextBufferSettings, QgsTextFormat,
                           QgsVectorLayerSimpleLabeling)

    pal = QgsPalLayerSettings()
    pal.isExpression = True
    pal.fieldName = expression
    fmt = QgsTextFormat()
    if colour is not None:
        fmt.setColor(QColor(colour))
    fmt.setSize(size)
    buf = QgsTextBufferSettings()
    buf.setEnabled(True)
    buf.setColor(QColor("#ffffff"))
    fmt.setBuffer(buf)
    pal.setFormat(fmt)
    lyr.setLabeling(QgsVectorLayerSimpleLabeling(pal))
    lyr.setLabelsEnabled(True)


def stands_style(out):
    """Stands: a blue outline, no fill, labelled with the stand id and its trees per hectare."""
    from qgis.core import QgsSingleSymbolRenderer

    lyr = QgsVectorLayer("Polygon?field=stand_id:string&field=trees_per_ha:double", "stands",
                         "memory")
    lyr.setRenderer(QgsSingleSymbolRenderer(QgsFillSymbol.createSimple(
        {"style": "no", "outline_color": "#08519c", "outline_width": "0.8"})))
    label(lyr, "\"stand_id\" || '\\n' || format_number(\"trees_per_ha\", 0) || ' trees/ha'",
          10, "#08519c")
    lyr.saveNamedStyle(str(out))


#: wood volume classes (m³/ha) and colours (ColorBrewer YlOrBr): the volume raster and stands
VOLUME_BREAKS = [0, 100, 200, 300, 400, 500, 600, 2000]
VOLUME_COLOURS = ["#ffffd4", "#fee391", "#fec44f", "#fe9929", "#ec7014", "#cc4c02", "#8c2d04"]


def volume_style(path, out):
    """The volume raster (m³/ha) in 100 m³/ha classes."""
    lyr = QgsRasterLayer(str(path), "volume")
    shader = QgsRasterShader()
    fn = QgsColorRampShader(0.0, 700.0)
    fn.setColorRampType(QgsColorRampShader.Discrete)
    lows, highs = VOLUME_BREAKS[:-1], VOLUME_BREAKS[1:]
    fn.setColorRampItemList([QgsColorRampShader.ColorRampItem(
        hi, QColor(c), f"{lo:g} - {hi:g} m³/ha" if hi < 2000 else f"> {lo:g} m³/ha")
        for lo, hi, c in zip(lows, highs, VOLUME_COLOURS)])
    shader.setRasterShaderFunction(fn)
    rend = QgsSingleBandPseudoColorRenderer(lyr.dataProvider(), 1, shader)
    rend.setClassificationMin(0.0)
    rend.setClassificationMax(700.0)
    lyr.setRenderer(rend)
    lyr.saveNamedStyle(str(out))


def volume_stands_style(out):
    """Stands of the volume command: filled by volume_m3_ha, labelled with the stand id, its
    volume and the 95 % interval."""
    lyr = QgsVectorLayer("Polygon?field=stand_id:string&field=volume_m3_ha:double"
                         "&field=volume_m3_ha_low:double&field=volume_m3_ha_high:double",
                         "stands", "memory")
    graduated(lyr, "volume_m3_ha", lambda c: QgsFillSymbol.createSimple(
        {"color": c, "outline_color": "#252525", "outline_width": "0.6"}), VOLUME_BREAKS,
        VOLUME_COLOURS)
    label(lyr, ("\"stand_id\" || '\\n' || format_number(\"volume_m3_ha\", 0) || ' m³/ha ("
                     "' || format_number(\"volume_m3_ha_low\", 0) || '-' || "
                     "format_number(\"volume_m3_ha_high\", 0) || ')'"), 9)
    lyr.saveNamedStyle(str(out))


def volume_plots_style(out):
    """Plots of the volume command: a dark outline, no fill, labelled with the plot id, its
    measured volume and the model's residual (m³/ha)."""
    from qgis.core import QgsSingleSymbolRenderer

    lyr = QgsVectorLayer("Polygon?field=plot_id:string&field=volume_m3_ha:double"
                         "&field=residual_m3_ha:double", "plots", "memory")
    lyr.setRenderer(QgsSingleSymbolRenderer(QgsFillSymbol.createSimple(
        {"style": "no", "outline_color": "#7f0000", "outline_width": "0.7"})))
    label(lyr, ("\"plot_id\" || '\\n' || format_number(\"volume_m3_ha\", 0) || ' m³/ha' || "
                "if(\"residual_m3_ha\" IS NULL, '', ' (' || format_number(\"residual_m3_ha\", 0)"
                " || ')')"), 8, "#7f0000")
    lyr.saveNamedStyle(str(out))


def volume_styles():
    """Only the volume command's styles (``make_styles.py volume``)."""
    with tempfile.TemporaryDirectory() as d:
        tif = Path(d) / "t.tif"
        tiny_raster(tif)
        volume_style(tif, HERE / "volume.qml")
    volume_stands_style(HERE / "volume_stands.qml")
    volume_plots_style(HERE / "volume_plots.qml")


def main():
    app = QgsApplication([], False)
    app.initQgis()
    if sys.argv[1:] == ["volume"]:
        volume_styles()
        app.exitQgis()
        return 0
    with tempfile.TemporaryDirectory() as d:
        tif = Path(d) / "t.tif"
        tiny_raster(tif)
        chm_style(tif, HERE / "chm.qml")
        dtm_style(tif, HERE / "dtm_hillshade.qml")
    # tops and crowns in reds and magentas, hues the green CHM does not have
    heights = [0, 10, 15, 20, 25, 30, 100]
    hcol = ["#fb6a4a", "#ef3b2c", "#e31a1c", "#cb181d", "#a50f15", "#67000d"]  # Reds
    pts = QgsVectorLayer("Point?field=height:double&field=crown_diameter:double", "tree_tops", "memory")
    graduated(pts, "height", lambda c: QgsMarkerSymbol.createSimple(
        {"name": "circle", "color": c, "outline_color": "#ffffff", "outline_width": "0.3",
         "size": "2"}), heights, hcol)
    pts.saveNamedStyle(str(HERE / "tree_tops.qml"))
    diam = [0, 2, 3, 4, 6, 8, 100]
    dcol = ["#f768a1", "#e7298a", "#dd3497", "#c51b8a", "#ae017e", "#7a0177"]  # RdPu
    polys = QgsVectorLayer("Polygon?field=height:double&field=crown_diameter:double", "crowns", "memory")
    graduated(polys, "crown_diameter", lambda c: QgsFillSymbol.createSimple(
        {"style": "no", "outline_color": c, "outline_width": "0.4"}), diam, dcol)
    polys.saveNamedStyle(str(HERE / "crowns.qml"))
    from qgis.core import QgsSingleSymbolRenderer

    from qgis.core import QgsCategorizedSymbolRenderer, QgsRendererCategory

    gaps = QgsVectorLayer("Point?field=gap_id:integer&field=status:string", "gaps", "memory")
    missing = QgsMarkerSymbol.createSimple(
        {"name": "cross2", "color": "#e31a1c", "outline_color": "#e31a1c", "outline_width": "0.6",
         "size": "3"})
    suppressed = QgsMarkerSymbol.createSimple(
        {"name": "circle", "color": "0,0,0,0", "outline_color": "#08519c",
         "outline_width": "0.5", "size": "2.4"})
    uncertain = QgsMarkerSymbol.createSimple(
        {"name": "triangle", "color": "0,0,0,0", "outline_color": "#ff7f00",
         "outline_width": "0.6", "size": "2.8"})
    gaps.setRenderer(QgsCategorizedSymbolRenderer("status", [
        QgsRendererCategory("missing", missing, "missing tree (gap)"),
        QgsRendererCategory("suppressed", suppressed, "suppressed tree (no top)"),
        QgsRendererCategory("uncertain", uncertain, "uncertain (field check)")]))
    gaps.saveNamedStyle(str(HERE / "gaps.qml"))
    stands_style(HERE / "stands.qml")
    volume_styles()
    app.exitQgis()
    print("styles written to", HERE)


if __name__ == "__main__":
    sys.exit(main())

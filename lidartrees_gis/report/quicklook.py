"""The quick-look PNG of a trees run: the CHM in height classes, crown outlines, tree tops, map
coordinates, a scale bar and the stand summary as its title."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .._version import __version__
from ..crs import crs_label
from .classes import height_classes, round_length


def _draw_stands(ax, ids, geoms) -> None:
    """Stand outlines (blue, not in the CHM's greens nor the crowns' magentas) with their ids."""
    import shapely

    for sid, g in zip(ids, geoms):
        for poly in getattr(g, "geoms", [g]):
            for ring in [poly.exterior, *poly.interiors]:
                x, y = np.asarray(ring.coords).T
                ax.plot(x, y, color="#08519c", linewidth=1.4, zorder=5)
        p = shapely.point_on_surface(g)
        ax.annotate(str(sid), (p.x, p.y), color="#08519c", fontsize=9, fontweight="bold",
                    ha="center", va="center", zorder=6,
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none",
                          "alpha": 0.7})
    ax.plot([], [], color="#08519c", linewidth=1.4, label=f"stands ({len(ids)})")


def write_quicklook(path, chm, labels, rows, cols, *, spec=None, title=None, overwrite=False,
                    gaps=None, stands=None, uncertain=None, suppressed=None):
    """Quick-look PNG: the CHM in colour classes with a legend, crown outlines and tree tops,
    the missing trees of plantation mode (``gaps``: map x, y), its suppressed trees
    (``suppressed``: map x, y; no crown of their own) and its positions left to a field check
    (``uncertain``: map x, y), map coordinates on the axes, a scale bar and a title (e.g. the
    stand summary). ``stands``: ``(ids, shapely polygons)`` drawn as outlines labelled with
    their ids, whole (the map reaches them beyond the data; map coordinates, needs ``spec``).

    ``spec`` (:class:`GridSpec`) gives the coordinates and scale bar; without it the axes are in
    cells. The title and the summary are also stored as PNG text (Title, Description).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..io.output import atomic_output

    fig, counts = quicklook_figure(chm, labels, rows, cols, spec=spec, title=title, gaps=gaps,
                                   stands=stands, uncertain=uncertain, suppressed=suppressed)
    title = fig._suptitle.get_text()
    with atomic_output(path, overwrite, param="-png") as tmp:
        fig.savefig(tmp, format="png", bbox_inches="tight", pad_inches=0.25,
                    metadata={"Title": title.split("\n")[0], "Description": title,
                              "Comment": f"tree tops {counts[0]}; suppressed trees "
                                         f"{counts[2]}; missing trees {counts[1]}",
                              "Software": f"lidartrees_gis {__version__}"})
    plt.close(fig)


def _marker_size(n: int, k: float) -> float:
    """A marker's size among ``n`` tops: the tops' (``k`` = 1) or ``k`` times larger."""
    return max(4.0 * k, 3000.0 / max(n, 1) ** 0.5 / 10 * k / (1.6 if k > 1 else 1))


def quicklook_figure(chm, labels, rows, cols, *, spec=None, title=None, gaps=None, stands=None,
                     uncertain=None, suppressed=None):
    """The quick look's matplotlib figure (see :func:`write_quicklook`) and the counts drawn
    ``(tops, missing, suppressed)``. Everything lies inside the figure: the legend under the
    map, the colour bar beside it; the lowest tick of each axis is left out, so the two do not
    meet in the corner."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm
    from matplotlib.ticker import MaxNLocator
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar
    from skimage.segmentation import find_boundaries

    a = np.asarray(chm, np.float64)
    h, w = a.shape
    finite = a[np.isfinite(a)]
    top = float(np.nanpercentile(finite, 99.5)) if finite.size else 1.0
    bounds = np.array([0.0] + height_classes(top))
    cmap = plt.get_cmap("YlGn", bounds.size - 1).with_extremes(bad="#d9d9d9")
    if spec is not None:
        left, right = spec.left, spec.left + w * spec.res
        bottom, topy = spec.top - h * spec.res, spec.top
        px = spec.res
    else:
        left, right, bottom, topy, px = 0.0, float(w), float(h), 0.0, 1.0
    extent = (left, right, bottom, topy)
    view = list(extent)
    if stands is not None and spec is not None and len(stands[0]):
        import shapely

        sb = shapely.total_bounds(np.asarray(stands[1], dtype=object))
        view = [min(left, sb[0]), max(right, sb[2]), min(bottom, sb[1]), max(topy, sb[3])]
    aspect = (view[3] - view[2]) / max(view[1] - view[0], 1e-9)
    fig_w = 9.0
    fig = plt.figure(figsize=(fig_w, min(max(fig_w * aspect * 0.85 + 1.8, 4.6), 14.0)), dpi=110)
    ax = fig.add_axes([0.1, 0.17, 0.72, 0.73])
    im = ax.imshow(np.ma.masked_invalid(np.clip(a, 0, None)), cmap=cmap,
                   norm=BoundaryNorm(bounds, cmap.N, clip=True), extent=extent,
                   interpolation="nearest")
    k = max(1, int(np.ceil(500 / max(h, w))))  # outlines on a finer grid stay thin
    lab = np.kron(np.asarray(labels), np.ones((k, k), dtype=np.asarray(labels).dtype))
    edge = find_boundaries(lab, mode="inner") & (lab > 0)
    ov = np.zeros(lab.shape + (4,))
    ov[edge] = (0.85, 0.0, 0.55, 1.0)  # magenta outlines: not in the CHM's greens
    ax.imshow(ov, extent=extent, interpolation="nearest")
    r, c = np.asarray(rows, float), np.asarray(cols, float)
    if spec is not None:
        tx, ty = left + (c + 0.5) * px, topy - (r + 0.5) * px
    else:
        tx, ty = c + 0.5, r + 0.5
    ax.scatter(tx, ty, s=_marker_size(len(r), 1), c="#e31a1c",
               edgecolors="white", linewidths=0.4, zorder=3,
               label=f"trees with a crown ({len(r):,})")
    n_gaps = n_sup = 0
    if suppressed is not None and len(suppressed[0]):
        sx, sy = (np.asarray(v, float) for v in suppressed)
        n_sup = sx.size
        ax.scatter(sx, sy, s=_marker_size(len(r), 4), marker="o", facecolors="none",
                   edgecolors="#6a3d9a", linewidths=1.3, zorder=4,
                   label=f"suppressed trees ({n_sup:,})")
    if gaps is not None and len(gaps[0]):
        gx, gy = (np.asarray(v, float) for v in gaps)  # map coordinates (needs spec)
        n_gaps = gx.size
        ax.scatter(gx, gy, s=_marker_size(len(r), 4), marker="x",
                   c="#000000", linewidths=1.2, zorder=4, label=f"missing trees ({n_gaps:,})")
    if uncertain is not None and len(uncertain[0]):
        ux, uy = (np.asarray(v, float) for v in uncertain)
        ax.scatter(ux, uy, s=_marker_size(len(r), 4), marker="^",
                   facecolors="none", edgecolors="#ff7f00", linewidths=1.2, zorder=4,
                   label=f"uncertain, to check ({ux.size:,})")
    ax.plot([], [], color=(0.85, 0.0, 0.55), label="crowns")
    if stands is not None and spec is not None:
        _draw_stands(ax, *stands)
    ax.set_xlim(view[0], view[1])
    ax.set_ylim(view[2], view[3])
    ax.set_aspect("equal")
    ax.apply_aspect()  # the map's box as drawn: the legend goes right under it
    box = ax.get_position()
    fig.legend(*ax.get_legend_handles_labels(), loc="upper center", ncol=3, fontsize=8,
               frameon=False, bbox_to_anchor=(box.x0 + box.width / 2, max(box.y0 - 0.045,
                                                                         0.075)))
    for axis in (ax.xaxis, ax.yaxis):  # no two tick labels in the lower left corner
        axis.set_major_locator(MaxNLocator(nbins=6, prune="lower"))
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.tick_params(labelsize=7)
    for t in ax.get_yticklabels():
        t.set_rotation(90)
        t.set_va("center")
    unit = "m" if spec is not None else "cells"
    ax.set_xlabel(f"x ({unit})" + (f"  ·  {crs_label(spec.crs)}" if spec is not None and
                                    spec.crs is not None else ""), fontsize=8)
    ax.set_ylabel(f"y ({unit})", fontsize=8)
    span = (view[1] - view[0]) * 0.2
    bar = round_length(span) if span > 0 else 1.0
    ax.add_artist(AnchoredSizeBar(ax.transData, bar, f"{bar:g} {unit}", "lower right", pad=0.4,
                                  color="black", frameon=True, size_vertical=max(bar / 40, px)))
    cax = fig.add_axes([0.85, 0.45, 0.025, 0.45])
    cb = fig.colorbar(im, cax=cax, ticks=bounds)
    cb.set_label("canopy height (m)", fontsize=8)
    cb.ax.tick_params(labelsize=7)
    fig.suptitle(title or "lidartrees_gis quick look", fontsize=9)
    return fig, (len(r), n_gaps, n_sup)


def quicklook_title(summary: dict, source, title=None) -> str:
    """The quick-look title: ``title`` (default the input's name) and the stand summary on a
    second line."""
    def f(k, fmt):
        v = summary.get(k)
        return None if v is None or (isinstance(v, float) and not np.isfinite(v)) else fmt.format(v)

    parts = [f("trees", "{:,} trees"), f("trees_per_ha", "{:,.0f} trees/ha"),
             f("mean_height", "mean height {:.1f} m"),
             f("mean_crown_diameter", "crown diameter {:.1f} m"),
             f("stocking_pct", "stocking {:.1f} %")]
    name = title or (Path(str(source)).name if source else "CHM")
    return f"{name}\n" + " · ".join(p for p in parts if p)

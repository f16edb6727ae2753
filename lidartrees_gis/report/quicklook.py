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
                    gaps=None, stands=None, uncertain=None):
    """Quick-look PNG: the CHM in colour classes with a legend, crown outlines and tree tops,
    the missing trees of plantation mode (``gaps``: map x, y) and its positions left to a field
    check (``uncertain``: map x, y), map coordinates on the axes, a
    scale bar and a title (e.g. the stand summary). ``stands``: ``(ids, shapely polygons)``
    drawn as outlines labelled with their ids (map coordinates; needs ``spec``).

    ``spec`` (:class:`GridSpec`) gives the coordinates and scale bar; without it the axes are in
    cells. The title and the summary are also stored as PNG text (Title, Description).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar
    from skimage.segmentation import find_boundaries

    from ..io.output import atomic_output

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
    aspect = h / max(w, 1)
    fig_w = 9.0
    fig = plt.figure(figsize=(fig_w, min(max(fig_w * aspect * 0.85 + 1.2, 4.0), 14.0)), dpi=110)
    ax = fig.add_axes([0.1, 0.08, 0.72, 0.82])
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
    ax.scatter(tx, ty, s=max(4.0, 3000.0 / max(len(r), 1) ** 0.5 / 10), c="#e31a1c",
               edgecolors="white", linewidths=0.4, zorder=3, label=f"tree tops ({len(r):,})")
    n_gaps = 0
    if gaps is not None and len(gaps[0]):
        gx, gy = (np.asarray(v, float) for v in gaps)  # map coordinates (needs spec)
        n_gaps = gx.size
        ax.scatter(gx, gy, s=max(16.0, 3000.0 / max(len(r), 1) ** 0.5 / 4), marker="x",
                   c="#000000", linewidths=1.2, zorder=4, label=f"missing trees ({n_gaps:,})")
    if uncertain is not None and len(uncertain[0]):
        ux, uy = (np.asarray(v, float) for v in uncertain)
        ax.scatter(ux, uy, s=max(16.0, 3000.0 / max(len(r), 1) ** 0.5 / 4), marker="^",
                   facecolors="none", edgecolors="#ff7f00", linewidths=1.2, zorder=4,
                   label=f"uncertain, to check ({ux.size:,})")
    ax.plot([], [], color=(0.85, 0.0, 0.55), label="crowns")
    if stands is not None and spec is not None:
        _draw_stands(ax, *stands)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 0.2), fontsize=8, frameon=False)
    ax.set_xlim(left, right)
    ax.set_ylim(bottom, topy)
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.tick_params(labelsize=7)
    for t in ax.get_yticklabels():
        t.set_rotation(90)
        t.set_va("center")
    unit = "m" if spec is not None else "cells"
    ax.set_xlabel(f"x ({unit})" + (f"  ·  {crs_label(spec.crs)}" if spec is not None and
                                    spec.crs is not None else ""), fontsize=8)
    ax.set_ylabel(f"y ({unit})", fontsize=8)
    span = (right - left) * 0.2
    bar = round_length(span) if span > 0 else 1.0
    ax.add_artist(AnchoredSizeBar(ax.transData, bar, f"{bar:g} {unit}", "lower right", pad=0.4,
                                  color="black", frameon=True, size_vertical=max(bar / 40, px)))
    cax = fig.add_axes([0.85, 0.45, 0.025, 0.45])
    cb = fig.colorbar(im, cax=cax, ticks=bounds)
    cb.set_label("canopy height (m)", fontsize=8)
    cb.ax.tick_params(labelsize=7)
    title = title or "lidartrees_gis quick look"
    fig.suptitle(title, fontsize=9)
    with atomic_output(path, overwrite, param="-png") as tmp:
        fig.savefig(tmp, format="png", metadata={"Title": title.split("\n")[0],
                                                 "Description": title,
                                                 "Comment": f"tree tops {len(r)}; missing trees "
                                                            f"{n_gaps}",
                                                 "Software": f"lidartrees_gis {__version__}"})
    plt.close(fig)


def quicklook_title(summary: dict, source) -> str:
    """The quick-look title: the input's name and the stand summary in one or two lines."""
    def f(k, fmt):
        v = summary.get(k)
        return None if v is None or (isinstance(v, float) and not np.isfinite(v)) else fmt.format(v)

    parts = [f("trees", "{:,} trees"), f("trees_per_ha", "{:,.0f} trees/ha"),
             f("mean_height", "mean height {:.1f} m"),
             f("mean_crown_diameter", "crown diameter {:.1f} m"),
             f("stocking_pct", "stocking {:.1f} %")]
    name = Path(str(source)).name if source else "CHM"
    return f"{name}\n" + " · ".join(p for p in parts if p)

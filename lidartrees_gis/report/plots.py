"""Small PNG figures written by the file-level chains: DTM hillshades (ground quality sweep) and
one-axis plots (TLS taper and profile)."""
from __future__ import annotations

import numpy as np


# terrestrial scans (seeds 002 and 004)
def plot_png(path, draw, *, size=(6, 6), overwrite=False, widths=None, dpi=100):
    """A PNG of one axis drawn by ``draw(ax)``, or of several side by side (``draw`` a list,
    ``widths`` their relative widths), ``size`` inches at ``dpi``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..io.output import atomic_output

    draws = list(draw) if isinstance(draw, (list, tuple)) else [draw]
    fig, axes = plt.subplots(1, len(draws), figsize=size, dpi=dpi, squeeze=False,
                             gridspec_kw={"width_ratios": widths} if widths else None)
    for d, ax in zip(draws, axes[0]):
        d(ax)
    fig.tight_layout()
    with atomic_output(path, overwrite, param="PNG") as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def write_hillshade_png(path, dtm, res, title="", overwrite=False):
    """Hillshade (azimuth 315°, altitude 45°) of a DTM as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LightSource

    from ..io.output import atomic_output

    a = np.asarray(dtm, dtype=np.float64)
    fill = np.nanmean(a) if np.isfinite(a).any() else 0.0
    hs = LightSource(azdeg=315, altdeg=45).hillshade(np.where(np.isfinite(a), a, fill), dx=res, dy=res)
    fig = plt.figure(figsize=(6, 6 * a.shape[0] / max(a.shape[1], 1)), dpi=100)
    ax = fig.add_axes([0, 0, 1, 0.94])
    ax.imshow(hs, cmap="gray", interpolation="nearest")
    ax.set_axis_off()
    fig.suptitle(title, fontsize=9)
    with atomic_output(path, overwrite, param="PNG") as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)

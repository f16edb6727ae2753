"""Field inventory: the measured trees of the plots (a pt-BR table as crews export it), their
heights, volumes and the plots' per-hectare figures.

A tree table has one row a tree: the plot id (``parcela``), the tree (``arvore``), DAP in cm
(``dap``; or the circumference ``cap`` in cm, DAP = CAP / π), the total height HT in m
(``ht``; for all or some trees) and optionally the tree's volume in m³ (``volume``). Column
names in Portuguese or English, ``;`` and decimal comma or ``,`` and decimal point
(:func:`lidartrees_gis.io.names.read_text_table`).

* trees without HT get it from the hypsometric relation ``ln HT = a + b / DAP`` (Curtis),
  fitted on the trees with HT;
* trees without a volume get it from Schumacher-Hall ``V = b0 DAP^b1 HT^b2`` (DAP cm, HT m,
  V m³): the given coefficients, or fitted (``ln V = ln b0 + b1 ln DAP + b2 ln HT``) on the
  trees that carry a volume.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, listing
from ..io.names import normalise

#: the names accepted for each column of a tree table (normalised, see io.names.normalise)
FIELD_COLUMNS = {
    "plot": ("parcela", "plot", "plotid", "idparcela", "codparcela", "numparcela", "parc",
             "plotnumber"),
    "tree": ("arvore", "arv", "tree", "treeid", "idarvore", "numarvore", "fuste", "individuo"),
    "dap": ("dap", "dbh", "dapcm", "dbhcm", "diametro", "d"),
    "cap": ("cap", "cbh", "capcm", "circunferencia", "circ"),
    "ht": ("ht", "h", "altura", "alturatotal", "height", "htm", "htotal"),
    "volume": ("volume", "vol", "v", "volm3", "volumem3", "vtcc", "vcc", "volumetotal"),
}
#: a DAP median above this (cm) is taken for millimetres and refused
DAP_MM = 100.0


@dataclass(frozen=True)
class Equation:
    """Schumacher-Hall ``V = b0 DAP^b1 HT^b2`` (DAP cm, HT m, V m³). A form factor ``f``
    (``V = f · g · HT``, ``g = π DAP² / 40000`` m²) is the case ``b0 = f π / 40000``,
    ``b1 = 2``, ``b2 = 1`` (:meth:`parse` takes it as ``ff:F``)."""

    b0: float
    b1: float
    b2: float
    source: str = "given"  # given | fitted on N trees

    @classmethod
    def parse(cls, text) -> "Equation":
        t = str(text).strip()
        if t.lower().startswith(("ff:", "ff=")):  # a form factor (fator de forma), "ff:0,45"
            try:
                f = float(t[3:].strip().replace(",", "."))
            except ValueError:
                f = np.nan
            if not 0.1 <= f <= 1.5:
                raise InputError(f"-volume_equation: expected ff:F with a form factor F between "
                                 f"0.1 and 1.5 (V = F·g·HT), got {text!r}")
            return cls(f * np.pi / 40000.0, 2.0, 1.0, source=f"form factor {f:g}")
        try:  # pt-BR: "0,000049;1,85;1,05"
            parts = [v.replace(",", ".") for v in t.split(";")] if ";" in t else t.split(",")
            vals = [float(v) for v in parts]
            if len(vals) != 3 or not vals[0] > 0:
                raise ValueError
        except ValueError:
            raise InputError(f"-volume_equation: expected b0,b1,b2 (V = b0·DAP^b1·HT^b2, b0 > "
                             f"0) or ff:F (a form factor), got {text!r}") from None
        return cls(*vals)

    def __call__(self, dap, ht):
        return self.b0 * np.asarray(dap, float) ** self.b1 * np.asarray(ht, float) ** self.b2


def _columns(df, path) -> dict:
    found = {}
    for c in df.columns:
        key = normalise(c)
        for attr, names in FIELD_COLUMNS.items():
            if attr not in found and (key in names or key == attr):
                found[attr] = c
    if "plot" not in found:
        raise InputError(f"-trees_table: {path}: no plot column (parcela, plot); columns: "
                         f"{', '.join(map(str, df.columns))}")
    if "dap" not in found and "cap" not in found:
        raise InputError(f"-trees_table: {path}: no DAP (dap, dbh) or CAP (cap) column; "
                         f"columns: {', '.join(map(str, df.columns))}")
    return found


def _numbers(df, col, path, what):
    import pandas as pd

    v = pd.to_numeric(df[col].astype(str).str.replace(",", ".").str.strip()
                      .replace({"": None, "nan": None, "NA": None}), errors="coerce")
    bad = v.isna() & df[col].notna() & (df[col].astype(str).str.strip() != "")
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise InputError(f"-trees_table: {path}: line {i + 2}: {what} {df[col].iloc[i]!r} is not "
                         "a number")
    return v.to_numpy(dtype=float)


def read_trees(path) -> dict:
    """The tree table as arrays: ``plot`` (str), ``tree``, ``dap`` (cm), ``ht`` (m, NaN where
    not measured), ``volume`` (m³, NaN where not given). Refuses a DAP in millimetres."""
    from ..io.names import read_text_table

    try:
        df = read_text_table(path)
    except (ValueError, OSError) as exc:
        raise InputError(f"-trees_table: {path}: cannot read the table ({exc})") from None
    if len(df) == 0:
        raise InputError(f"-trees_table: {path}: no trees")
    cols = _columns(df, path)
    plot = [str(int(v)) if isinstance(v, float) and float(v).is_integer() else str(v).strip()
            for v in df[cols["plot"]].tolist()]
    if "dap" in cols:
        dap = _numbers(df, cols["dap"], path, "DAP")
        name, limit = "DAP", DAP_MM
    else:
        dap = _numbers(df, cols["cap"], path, "CAP") / np.pi
        name, limit = "CAP", DAP_MM * np.pi
    ok = np.isfinite(dap) & (dap > 0)
    if not ok.any():
        raise InputError(f"-trees_table: {path}: no tree with a {name} above 0")
    med = float(np.median(dap[ok]))
    if med > DAP_MM:
        col = cols.get("dap", cols.get("cap"))
        raise InputError(f"-trees_table: {path}: {name} column {col!r} has a median of "
                         f"{med * (1 if name == 'DAP' else np.pi):.0f} (above {limit:.0f}): "
                         "millimetres? give centimetres (divide by 10)")
    n = len(df)
    ht = _numbers(df, cols["ht"], path, "HT") if "ht" in cols else np.full(n, np.nan)
    vol = _numbers(df, cols["volume"], path, "volume") if "volume" in cols else np.full(n, np.nan)
    tree = df[cols["tree"]].astype(str).to_numpy() if "tree" in cols else \
        np.arange(1, n + 1).astype(str)
    dead = ~ok  # a row without DAP (a dead or missing tree noted by the crew): left out
    keep = ~dead
    return {"plot": np.asarray(plot, dtype=object)[keep], "tree": tree[keep], "dap": dap[keep],
            "ht": np.where(ht > 0, ht, np.nan)[keep], "volume": vol[keep],
            "rows_without_dap": int(dead.sum()), "path": str(path)}


def fit_hypsometric(dap, ht) -> tuple:
    """Curtis ``ln HT = a + b / DAP`` by least squares: ``(a, b, n, rmse_m)``."""
    ok = np.isfinite(dap) & np.isfinite(ht) & (dap > 0) & (ht > 0)
    if ok.sum() < 3:
        raise InputError(f"-trees_table: only {int(ok.sum())} trees with a height (HT); the "
                         "heights of the others need at least 3 measured")
    X = np.column_stack([np.ones(ok.sum()), 1.0 / dap[ok]])
    coef, *_ = np.linalg.lstsq(X, np.log(ht[ok]), rcond=None)
    pred = np.exp(X @ coef)
    rmse = float(np.sqrt(np.mean((pred - ht[ok]) ** 2)))
    return float(coef[0]), float(coef[1]), int(ok.sum()), rmse


def fit_schumacher(dap, ht, vol) -> Equation:
    """Schumacher-Hall fitted on the trees with a volume (log-linear least squares with the
    Meyer correction exp(s²/2) in b0)."""
    ok = np.isfinite(dap) & np.isfinite(ht) & np.isfinite(vol) & (vol > 0)
    if ok.sum() < 5:
        raise InputError(f"-trees_table: {int(ok.sum())} trees carry a volume: give "
                         "-volume_equation b0,b1,b2 (Schumacher-Hall V = b0·DAP^b1·HT^b2, DAP "
                         "cm, HT m) or at least 5 trees with their volume")
    X = np.column_stack([np.ones(ok.sum()), np.log(dap[ok]), np.log(ht[ok])])
    y = np.log(vol[ok])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    s2 = float(np.sum((y - X @ coef) ** 2) / max(ok.sum() - 3, 1))
    return Equation(float(np.exp(coef[0] + s2 / 2)), float(coef[1]), float(coef[2]),
                    f"fitted on {int(ok.sum())} trees")


def complete_trees(trees: dict, equation: Equation | None) -> dict:
    """The tree table with every tree's HT (measured, or from the hypsometric relation) and
    volume (given, or from the equation); ``equation`` None fits Schumacher-Hall on the trees
    that carry a volume. Adds ``ht_estimated`` (bool), ``hypsometric`` and ``equation``."""
    t = dict(trees)
    dap, ht, vol = t["dap"], t["ht"].copy(), t["volume"].copy()
    missing = ~np.isfinite(ht)
    t["hypsometric"] = None
    if missing.any():
        a, b, n, rmse = fit_hypsometric(dap, ht)
        ht[missing] = np.exp(a + b / dap[missing])
        t["hypsometric"] = {"form": "ln(HT) = a + b / DAP", "a": a, "b": b, "trees": n,
                            "rmse_m": rmse}
    if equation is None and np.isfinite(vol).all():
        eq = None
    else:
        eq = equation or fit_schumacher(dap, ht, vol)
        vol = np.where(np.isfinite(vol), vol, eq(dap, ht))
    t.update(ht=ht, volume=vol, ht_estimated=missing, equation=eq)
    return t


def plot_figures(trees: dict, plot_ids, plot_area_m2) -> dict:
    """Per plot (in the order of ``plot_ids``): ``volume_m3_ha``, ``basal_area_m2_ha``,
    ``trees_ha``, ``n_trees``, ``mean_ht``. Refuses plots that have no tree and trees of no
    plot of the layer."""
    ids = [str(p) for p in plot_ids]
    index = {p: i for i, p in enumerate(ids)}
    k = np.array([index.get(str(p), -1) for p in trees["plot"]])
    if (k < 0).all():
        raise InputError(f"-trees_table: {trees['path']}: none of its plot ids "
                         f"({listing(sorted(set(map(str, trees['plot']))))}) is a plot of "
                         f"PLOTS ({listing(ids)}); check -plot_id")
    n = np.bincount(k[k >= 0], minlength=len(ids))
    empty = [ids[i] for i in np.flatnonzero(n == 0)]
    extra = sorted(set(str(p) for p, i in zip(trees["plot"], k) if i < 0))
    if empty:
        raise InputError(f"PLOTS: {len(empty)} plots have no trees in {trees['path']}: "
                         f"{listing(empty, 8)}"
                         + (f" (its plots not in PLOTS: {listing(extra, 8)})" if extra else "")
                         + "; drop them from the plots layer or add their trees")
    sel = k >= 0
    ha = np.asarray(plot_area_m2, float) / 1e4
    g = np.pi * (trees["dap"][sel] / 200.0) ** 2
    vol = np.bincount(k[sel], weights=trees["volume"][sel], minlength=len(ids))
    ba = np.bincount(k[sel], weights=g, minlength=len(ids))
    mh = np.bincount(k[sel], weights=trees["ht"][sel], minlength=len(ids)) / n
    # the plot volume's sampling variance from its own trees: n s²(v) / area² (what the plot
    # figure would vary by from one plot of these trees to another in the same stand)
    v = trees["volume"][sel]
    vm = vol / np.maximum(n, 1)
    ss = np.bincount(k[sel], weights=(v - vm[k[sel]]) ** 2, minlength=len(ids))
    noise = n * ss / np.maximum(n - 1, 1) / ha ** 2
    return {"volume_m3_ha": vol / ha, "basal_area_m2_ha": ba / ha, "trees_ha": n / ha,
            "sampling_var_m3_ha": noise,
            "n_trees": n.astype(float), "mean_ht": mh,
            "unmatched_trees": int((~sel).sum()), "unmatched_plots": extra}

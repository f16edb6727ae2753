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
    "ht": ("ht", "h", "alt", "altm", "altura", "alturatotal", "alturam", "height", "htm", "htotal"),
    "volume": ("volume", "vol", "v", "volm3", "volumem3", "vtcc", "vcc", "volumetotal"),
}
#: a DAP median above this (cm) is taken for millimetres and refused
DAP_MM = 100.0
#: a DAP median below this (cm) is taken for metres and refused
DAP_MIN_CM = 1.0
#: an HT median above this (m) is taken for centimetres or decimetres and refused
HT_MAX_M = 80.0
#: a median DAP (cm) per metre of HT above this is taken for a DAP in millimetres (stems:
#: 0.4-1.5; in millimetres 4-15)
DAP_PER_HT_MAX = 3.0
#: the median artificial form factor V / (g·HT) a tree table's volumes may have (stems:
#: 0.35-0.6; a b0 10 times off, or dm³, falls outside)
FORM_RANGE = (0.15, 1.5)
#: a plot basal area (m²/ha) above this is refused: few forests of any kind carry it (plantations
#: 10-60), a circumference (CAP) read as DAP gives pi² times the true figure
BA_MAX_M2_HA = 250.0


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
                             f"0: of ln V = ln b0 + ..., give exp(ln b0)) or ff:F (a form "
                             f"factor), got {text!r}") from None
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


def _numbers(df, col, path, what, frame: bool = False):
    """The column as floats (decimal commas read); a cell that is no number refused by its
    line in the file (its row in a DataFrame: ``frame``)."""
    import pandas as pd

    v = pd.to_numeric(df[col].astype(str).str.replace(",", ".").str.strip()
                      .replace({"": None, "nan": None, "NA": None}), errors="coerce")
    bad = v.isna() & df[col].notna() & (df[col].astype(str).str.strip() != "")
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        where = f"row {i}" if frame else f"line {i + 2}"
        raise InputError(f"-trees_table: {path}: {where}: {what} {df[col].iloc[i]!r} is not "
                         "a number")
    return v.to_numpy(dtype=float)


def table_label(table) -> str:
    """How a tree table is named in messages and reports: its path, or a DataFrame's rows."""
    import pandas as pd

    if isinstance(table, pd.DataFrame):
        return f"<DataFrame of {len(table)} rows>"
    return str(table)


def read_trees(path) -> dict:
    """The tree table as arrays: ``plot`` (str), ``tree``, ``dap`` (cm), ``ht`` (m, NaN where
    not measured), ``volume`` (m³, NaN where not given). Refuses a DAP in millimetres.
    ``path``: a CSV, text or ``.xlsx`` table (:func:`~..io.names.read_text_table`), or a
    pandas DataFrame with the same columns."""
    import pandas as pd

    from ..io.names import read_text_table

    frame = isinstance(path, pd.DataFrame)
    if frame:
        df, path = path.reset_index(drop=True), table_label(path)
    else:
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
        dap = _numbers(df, cols["dap"], path, "DAP", frame)
        name, limit = "DAP", DAP_MM
    else:
        dap = _numbers(df, cols["cap"], path, "CAP", frame) / np.pi
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
    if med < DAP_MIN_CM:
        col = cols.get("dap", cols.get("cap"))
        raise InputError(f"-trees_table: {path}: {name} column {col!r} has a median of "
                         f"{med * (1 if name == 'DAP' else np.pi):.3g} (a DAP below "
                         f"{DAP_MIN_CM:g} cm): metres? give centimetres (multiply by 100)")
    n = len(df)
    if "ht" not in cols:  # the heights of the trees without one come from those measured
        raise InputError(f"-trees_table: {path}: no HT column (ht, altura, alt, h); columns: "
                         f"{', '.join(map(str, df.columns))}")
    ht = _numbers(df, cols["ht"], path, "HT", frame)
    _check_heights(ht, dap, ok, path, cols)
    vol = _numbers(df, cols["volume"], path, "volume", frame) if "volume" in cols else np.full(n, np.nan)
    tree = df[cols["tree"]].astype(str).to_numpy() if "tree" in cols else \
        np.arange(1, n + 1).astype(str)
    dead = ~ok  # a row without DAP (a dead or missing tree noted by the crew): left out
    keep = ~dead
    return {"plot": np.asarray(plot, dtype=object)[keep], "tree": tree[keep], "dap": dap[keep],
            "ht": np.where(ht > 0, ht, np.nan)[keep], "volume": vol[keep],
            "rows_without_dap": int(dead.sum()), "path": str(path),
            "dap_column": f"{name} column {cols.get('dap', cols.get('cap'))!r}"}


def _check_heights(ht, dap, ok, path, cols) -> None:
    """Refuse heights in centimetres or decimetres, and a DAP in millimetres that the DAP
    column alone does not show (a young stand's: median 85 mm) but its ratio to HT does."""
    h = np.isfinite(ht) & (ht > 0)
    if not h.any():
        return
    med = float(np.median(ht[h]))
    if med > HT_MAX_M:
        raise InputError(f"-trees_table: {path}: HT column {cols['ht']!r} has a median of "
                         f"{med:.0f} (above {HT_MAX_M:g} m): centimetres or decimetres? give "
                         "metres")
    both = h & ok
    if both.sum() >= 5:
        r = float(np.median(dap[both] / ht[both]))
        if r > DAP_PER_HT_MAX:
            col = cols.get("dap", cols.get("cap"))
            raise InputError(f"-trees_table: {path}: DAP from {col!r} is {r:.1f} cm per metre "
                             f"of HT at the median (trees: 0.4-1.5): millimetres? give "
                             "centimetres (divide by 10)")


def form_factors(trees: dict) -> np.ndarray:
    """Each tree's artificial form factor ``V / (g · HT)`` (``g = π DAP² / 40000`` m²)."""
    g = np.pi * np.asarray(trees["dap"], float) ** 2 / 40000.0
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(trees["volume"], float) / (g * np.asarray(trees["ht"], float))


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
                         "cm, HT m), or ff:F (a form factor), or at least 5 trees with their "
                         "volume")
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
    given = np.isfinite(vol)
    if given.any():  # the table's own volumes: a column in dm³, or of another quantity
        _check_form({"dap": dap[given], "ht": ht[given], "volume": vol[given]},
                    f"-trees_table: {t.get('path')}: volume column")
    if equation is None and given.all():
        eq = None
    else:
        eq = equation or fit_schumacher(dap, ht, vol)
        if equation is not None:
            _check_form({"dap": dap, "ht": ht, "volume": eq(dap, ht)},
                        f"-volume_equation {eq.b0:g},{eq.b1:g},{eq.b2:g}")
        vol = np.where(given, vol, eq(dap, ht))
    t.update(ht=ht, volume=vol, ht_estimated=missing, equation=eq)
    return t


def _check_form(trees, what) -> None:
    """Refuse volumes whose median form factor no stem has (a coefficient mistyped, b0 of the
    logarithmic form, a volume column in dm³)."""
    f = form_factors(trees)
    f = f[np.isfinite(f)]
    if f.size and not FORM_RANGE[0] <= float(np.median(f)) <= FORM_RANGE[1]:
        raise InputError(f"{what}: the plots' trees' median form factor V / (g·HT) is "
                         f"{float(np.median(f)):.3g}, outside {FORM_RANGE[0]:g}-"
                         f"{FORM_RANGE[1]:g} (eucalyptus: about 0.45): check the coefficients "
                         "(b0 of V, not of ln V) or the volume's unit (m³)")


def _id_key(p) -> str:
    """A plot id as the table and the layer are matched: a number without its leading zeros
    (``01`` of a spreadsheet is plot ``1`` of the layer), anything else as written."""
    s = str(p).strip()
    return str(int(s)) if s.isdigit() else s


def plot_figures(trees: dict, plot_ids, plot_area_m2) -> dict:
    """Per plot (in the order of ``plot_ids``): ``volume_m3_ha``, ``basal_area_m2_ha``,
    ``trees_ha``, ``n_trees``, ``mean_ht``. Refuses plots that have no tree and trees of no
    plot of the layer."""
    ids = [str(p) for p in plot_ids]
    index = {_id_key(p): i for i, p in enumerate(ids)}
    k = np.array([index.get(_id_key(p), -1) for p in trees["plot"]])
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
    top = int(np.argmax(ba / ha))
    if ba[top] / ha[top] > BA_MAX_M2_HA:
        raise InputError(f"-trees_table: {trees['path']}: plot {ids[top]}'s basal area is "
                         f"{ba[top] / ha[top]:.0f} m²/ha from its "
                         f"{trees.get('dap_column', 'DAP')} (over "
                         f"{BA_MAX_M2_HA:g}; plantations carry 10-60): a circumference (CAP) in a "
                         "DAP column (name it cap), or a plot smaller than it is (check "
                         "-plot_radius)?")
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

"""Plot-level models and stand estimates with their intervals.

Area-based approach (ABA): ordinary least squares of a plot figure (volume m³/ha, basal area
m²/ha) on one height metric (:data:`HEIGHTS`), then optionally one canopy density metric
(:data:`DENSITIES`), then one height spread (:data:`SPREADS`), in one of two forms,

* ``linear``: ``Y = b0 + Σ bk Xk``;
* ``loglog``: ``ln Y = b0 + Σ bk ln Xk``, back-transformed with ``exp(s²/2)`` (Baskerville);

the form and the metrics chosen by their leave-one-out RMSE on the plots (each plot predicted
by the model fitted without it, in closed form from the hat matrix), a model with one more
metric kept only when it lowers that RMSE by :data:`PARSIMONY`. At most ``(n - 2) // 3``
metrics for ``n`` plots (3 plots per coefficient beyond the intercept and 2 more), so a model
needs at least :data:`MIN_PLOTS` plots.

Stand estimates: the mean of the model's cell predictions in the stand (cells of the plots'
size, and the pieces of cells its border cuts, each by its area: :class:`~.cells.CellShares`).
Their 95 % interval ``estimate ± t(0.975, n - p - 1) · sqrt(V_boot + σ²_stand)``:
``V_boot`` the variance of the stand's estimate over bootstrap resamples of the plots (the model
chosen again on each resample's distinct plots and refitted on the resample, :data:`BOOTSTRAP`
resamples; the variance of a normal with their central 95 %
range, robust to the wild refits of resamples of few distinct plots; inflated by
``n / (n - p - 1)``), ``σ²_stand``
the variance of a stand's departure from the model (:func:`stand_variance`: the between-stand
variance of the plots' leave-one-out residuals -- each plot predicted by the model chosen
and fitted without it (:func:`nested_loo`) --, or what their mean square holds beyond the
plots' own sampling variance computed from their trees, the larger) plus the residual variance
over the stand's cells. With ``stand_effect`` (the default) a stand's figure is moved by its
own plots' mean residual, weighted by how far they can be trusted (:func:`stand_effects`),
and its departure variance becomes the corrected figure's.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from .cells import CellShares

#: the metrics a model may take: one of the heights, then one of the canopy densities, then
#: one of the height spreads (a model of k metrics takes the first k groups)
HEIGHTS = ("zq95", "zq75", "zq50", "zmean", "zmax")
DENSITIES = ("cover", "pzabovezmean")
SPREADS = ("zsd", "zL2")
CANDIDATES = HEIGHTS + DENSITIES + SPREADS
FORMS = ("linear", "loglog")
#: a model with one more metric must lower the leave-one-out RMSE by this fraction
PARSIMONY = 0.02
MAX_PREDICTORS = 3
#: what the choice minimises: the plots' leave-one-out RMSE of relative errors ((pred - y) / y),
#: so that young stands weigh as much as old ones in a stand's relative error
SCORE = "loo_rel_rmse_pct"
MIN_PLOTS = 5
BOOTSTRAP = 400
#: a stand's own plots correct the model's figure only when the plots' residuals differ
#: between stands at this level (one-way analysis of variance, :func:`between_variance`)
STAND_ALPHA = 0.05
#: the plots' spread within stands enters a stand's weight at this lower quantile of its
#: chi-square (its upper 80 % bound), :func:`stand_effects`
WITHIN_BOUND = 0.2


def max_predictors(n: int) -> int:
    """The most metrics a model of ``n`` plots may take: 3 plots a metric and 2 more."""
    return max(0, min(MAX_PREDICTORS, (n - 2) // 3))


def check_plots(n: int, what: str = "an area-based model") -> None:
    if n < MIN_PLOTS:
        raise InputError(f"PLOTS: {n} plots with a measurement; {what} needs at least "
                         f"{MIN_PLOTS} (3 per metric + 2: 5 for one metric, 8 for two, 11 for "
                         "three)")


@dataclass(frozen=True)
class AbaModel:
    """A fitted plot-level model."""

    form: str
    predictors: tuple
    coef: np.ndarray
    s2: float  # residual variance on the fitting scale
    n: int
    target: str = "volume_m3_ha"
    stats: dict = field(default_factory=dict)

    def design(self, metrics: dict) -> np.ndarray:
        return _design(metrics, self.predictors, self.form)

    def predict(self, metrics: dict) -> np.ndarray:
        X = self.design(metrics)
        with np.errstate(invalid="ignore", over="ignore"):
            eta = X @ self.coef
            return np.exp(eta + self.s2 / 2) if self.form == "loglog" else eta

    def equation(self) -> str:
        terms = [f"{self.coef[0]:.6g}"] + [
            f"{c:+.6g}·{'ln ' if self.form == 'loglog' else ''}{p}"
            for c, p in zip(self.coef[1:], self.predictors)]
        lhs = f"ln({self.target})" if self.form == "loglog" else self.target
        return f"{lhs} = {' '.join(terms)}"


def _design(metrics: dict, predictors, form: str) -> np.ndarray:
    cols = [np.asarray(metrics[p], float) for p in predictors]
    if form == "loglog":
        with np.errstate(invalid="ignore", divide="ignore"):
            cols = [np.where(c > 0, np.log(c), np.nan) for c in cols]
    n = len(np.asarray(metrics[next(iter(metrics))]))
    return np.column_stack([np.ones(n)] + cols)


def _ols(X, y):
    """Coefficients, fitted values, leverages (None when singular)."""
    XtX = X.T @ X
    try:
        inv = np.linalg.inv(XtX)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(inv)) or np.linalg.cond(XtX) > 1e12:
        return None
    coef = inv @ X.T @ y
    h = np.einsum("ij,jk,ik->i", X, inv, X)
    return coef, X @ coef, h


def _loo(X, y, form: str):
    """``(coef, s2, fitted, loo)`` on the original scale, or None."""
    yt = np.log(y) if form == "loglog" else y
    r = _ols(X, yt)
    if r is None or np.any(r[2] > 1 - 1e-9):
        return None
    coef, fit, h = r
    e = yt - fit
    dof = max(len(y) - X.shape[1], 1)
    s2 = float(e @ e / dof)
    loo_t = yt - e / (1 - h)
    if form == "loglog":
        return coef, s2, np.exp(fit + s2 / 2), np.exp(loo_t + s2 / 2)
    return coef, s2, fit, loo_t


def fit_form(metrics: dict, y, predictors, form: str, target: str) -> AbaModel | None:
    X = _design(metrics, predictors, form)
    if not np.isfinite(X).all() or (form == "loglog" and np.any(np.asarray(y) <= 0)):
        return None
    r = _loo(X, np.asarray(y, float), form)
    if r is None:
        return None
    coef, s2, fit, loo = r
    return AbaModel(form, tuple(predictors), coef, s2, len(y), target,
                    {"fitted": fit, "loo": loo, **fit_stats(y, fit, loo, len(predictors))})


def fit_stats(y, fit, loo, p: int) -> dict:
    """R², adjusted R², RMSE, bias (in the unit and % of the mean) of the fit and the
    leave-one-out predictions."""
    y = np.asarray(y, float)
    n, mean = y.size, float(np.mean(y))
    ss = float(np.sum((y - mean) ** 2))
    r2 = 1 - float(np.sum((y - fit) ** 2)) / ss if ss > 0 else float("nan")
    rmse = float(np.sqrt(np.mean((y - fit) ** 2)))
    loo_rmse = float(np.sqrt(np.mean((y - loo) ** 2)))
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = float(np.sqrt(np.mean(((loo - y) / y) ** 2)))
    return {"r2": r2, "adj_r2": 1 - (1 - r2) * (n - 1) / max(n - p - 1, 1),
            "loo_rel_rmse_pct": 100 * rel,
            "rmse": rmse, "rmse_pct": 100 * rmse / mean, "bias": float(np.mean(fit - y)),
            "bias_pct": 100 * float(np.mean(fit - y)) / mean, "loo_rmse": loo_rmse,
            "loo_rmse_pct": 100 * loo_rmse / mean, "loo_bias": float(np.mean(loo - y)),
            "loo_r2": 1 - float(np.sum((y - loo) ** 2)) / ss if ss > 0 else float("nan")}


def candidate_sets(k: int) -> list:
    """The metric combinations of ``k`` metrics: a height, then a density, then a spread (a
    stand's volume grows with its height and with how much of it is covered; a free choice
    among all pairs of 8 plots picked unstable pairs that extrapolated badly)."""
    groups = (HEIGHTS, DENSITIES, SPREADS)[:k]
    return list(itertools.product(*groups))


def select_model(metrics: dict, y, target: str = "volume_m3_ha", *, forms=FORMS) -> tuple:
    """The model chosen by leave-one-out RMSE (see the module doc): ``(model, table)``, the
    table the best model of each size and form with its LOO RMSE."""
    y = np.asarray(y, float)
    check_plots(y.size)
    chosen, table = _choose(metrics, y, target, max_predictors(y.size), forms)
    if chosen is None:
        raise InputError(f"PLOTS: no model could be fitted on the {y.size} plots (the metrics "
                         "do not vary between them?)")
    return chosen, table


def _choose(metrics: dict, y, target: str, pmax: int, forms=FORMS) -> tuple:
    """:func:`select_model` with at most ``pmax`` metrics and no check of the plots' number:
    ``(model or None, table)``."""
    best_by_size, table = {}, []
    for k in range(1, pmax + 1):
        for form in forms:
            for combo in candidate_sets(k):
                m = fit_form(metrics, y, combo, form, target)
                if m is None:
                    continue
                cur = best_by_size.get(k)
                if cur is None or m.stats[SCORE] < cur.stats[SCORE]:
                    best_by_size[k] = m
        if k in best_by_size:
            b = best_by_size[k]
            table.append({"predictors": list(b.predictors), "form": b.form,
                          "loo_rmse_pct": round(b.stats["loo_rmse_pct"], 3),
                          "loo_rel_rmse_pct": round(b.stats["loo_rel_rmse_pct"], 3)})
    if not best_by_size:
        return None, table
    chosen = best_by_size[min(best_by_size)]
    for k in sorted(best_by_size)[1:]:
        if best_by_size[k].stats[SCORE] < chosen.stats[SCORE] * (1 - PARSIMONY):
            chosen = best_by_size[k]
    return chosen, table


def nested_loo(metrics: dict, y, target: str = "volume_m3_ha", *, forms=FORMS) -> np.ndarray:
    """Each plot predicted by the model chosen (:func:`select_model`'s rule and number of
    metrics for the ``n`` plots) and fitted without it: the leave-one-out
    prediction of the whole procedure, choice included. The chosen model's own leave-one-out
    residuals are the smallest of some 30 candidates' and so understate its error on plots
    it has not seen (with 5-6 plots, intervals built on them held 0.72 of the stands). NaN
    where no model could be fitted without the plot."""
    y = np.asarray(y, float)
    n = y.size
    pmax = max(1, max_predictors(n))
    out = np.full(n, np.nan)
    for i in range(n):
        keep = np.arange(n) != i
        sub = {k: np.asarray(v)[keep] for k, v in metrics.items()}
        m = _choose(sub, y[keep], target, pmax, forms)[0]
        if m is not None:
            one = {k: np.asarray(v)[i:i + 1] for k, v in metrics.items()}
            out[i] = float(m.predict(one)[0])
    return out


def between_variance(resid, stand, alpha: float | None = None) -> float:
    """Between-stand variance of plot residuals (one-way random effects, method of moments);
    0 when fewer than two stands hold two plots or more, or, with ``alpha``, when the
    one-way analysis of variance does not find the stands' means to differ at that level."""
    a = _anova(resid, stand)
    if a["stands_2plus"] < 2:
        return 0.0
    if alpha is not None and not (a["p"] is not None and a["p"] <= alpha):
        return 0.0
    return max(0.0, (a["msb"] - a["within"]) / a["n0"])


def _anova(resid, stand) -> dict:
    """The one-way analysis of variance of plot residuals by stand (plots outside the stands
    or without a residual left out): ``stands_2plus`` (stands with two plots or more), the
    mean squares ``within`` and between (``msb``), ``n0`` (the mean plots a stand of the
    method of moments), and ``f``, ``p`` (None without two such stands or any spread
    within)."""
    resid = np.asarray(resid, float)
    stand = np.asarray(stand)
    ok = (stand >= 0) & np.isfinite(resid)
    resid, stand = resid[ok], stand[ok]
    ids, inv, counts = np.unique(stand, return_inverse=True, return_counts=True)
    out = {"stands_2plus": int((counts >= 2).sum()), "f": None, "p": None}
    if out["stands_2plus"] < 2:
        return out
    from scipy import stats

    means = np.bincount(inv, weights=resid) / counts
    dof = resid.size - ids.size
    out["within"] = float(np.sum((resid - means[inv]) ** 2) / max(dof, 1))
    out["n0"] = (resid.size - np.sum(counts ** 2) / resid.size) / max(ids.size - 1, 1)
    out["msb"] = float(np.sum(counts * (means - resid.mean()) ** 2) / max(ids.size - 1, 1))
    if out["within"] > 0:
        out["f"] = out["msb"] / out["within"]
        out["p"] = float(stats.f.sf(out["f"], ids.size - 1, dof))
    return out


def stand_test(resid, stand) -> dict:
    """Why the stands' own plots do or do not correct them: the one-way analysis of variance
    of the plots' residuals by stand that :func:`between_variance` applies (``stands_2plus``:
    stands with two plots or more, ``f``, ``p``, ``alpha``, ``differ``)."""
    a = _anova(resid, stand)
    out = {"stands_2plus": a["stands_2plus"], "alpha": STAND_ALPHA, "f": None, "p": None,
           "differ": False}
    if a["stands_2plus"] < 2:
        out["why"] = "fewer than two stands hold two plots: the stands cannot be told apart"
    elif a["p"] is not None:
        out.update(f=round(a["f"], 3), p=round(a["p"], 4))
        out["differ"] = out["p"] <= STAND_ALPHA
    return out


def boot_variance(reps, n: int) -> np.ndarray:
    """A variance robust to the few wild refits of small resamples: that of a normal with the
    resamples' central 95 % range, ``((q97.5 - q2.5) / 3.92)²``."""
    if len(reps) < 10:
        return np.full(n, np.nan)
    q = np.nanpercentile(np.asarray(reps, float), [2.5, 97.5], axis=0)
    return ((q[1] - q[0]) / 3.92) ** 2


def t975(dof: int) -> float:
    from scipy import stats

    return float(stats.t.ppf(0.975, max(dof, 1)))


def stand_variance(resid_loo, plot_stand, plot_noise=None) -> float:
    """The variance of a stand's departure from the model: the between-stand variance of the
    plots' leave-one-out residuals (:func:`between_variance`), or, when larger, what their mean
    square holds beyond the plots' own sampling variance (``plot_noise``, from each plot's
    trees): a misfit of the model that the plots show but the stands cannot be told apart by."""
    s2 = between_variance(resid_loo, plot_stand)
    if plot_noise is not None:
        s2 = max(s2, float(np.mean(np.asarray(resid_loo) ** 2) - np.mean(plot_noise)))
    return s2


def plot_means(v, plot_stand, n_stands: int):
    """``(mean of v over each stand's plots, number of plots)``, 0 for a stand without a plot;
    plots outside the stands or with no value left out."""
    v = np.asarray(v, float)
    stand = np.asarray(plot_stand)
    ok = (stand >= 0) & (stand < n_stands) & np.isfinite(v)
    k = np.bincount(stand[ok], minlength=n_stands)[:n_stands].astype(float)
    return np.bincount(stand[ok], weights=v[ok], minlength=n_stands)[:n_stands] \
        / np.maximum(k, 1), k


def _stand_correction(resid, plot_stand, n_stands: int, s2_stand: float, plot_noise,
                      on: bool) -> dict:
    """:func:`stand_effects` with the between-stand variance taken only where the analysis of
    variance finds the stands to differ (:data:`STAND_ALPHA`); no weight when not ``on``."""
    return stand_effects(resid, plot_stand, n_stands, s2_stand, plot_noise,
                         s2_weight=between_variance(resid, plot_stand, STAND_ALPHA) if on
                         else 0.0)


def stand_effects(resid, plot_stand, n_stands: int, s2_stand: float, plot_noise=None,
                  s2_weight=None) -> dict:
    """Each stand's departure from the model as its own plots show it, shrunk by how far they
    can be trusted (the stand-level EBLUP of a one-way random effects model of the plots'
    residuals, Battese, Harter & Fuller 1988; Breidenbach & Astrup 2012 on forest stands):
    ``effect = γ · ē``, ``γ = σ²_b / (σ²_b + D)``, ``ē`` the mean residual of the stand's
    plots, ``σ²_b`` the between-stand variance (``s2_weight``, default ``s2_stand``) and ``D``
    the variance of ``ē``: the largest of the residuals' variance within stands (at its upper
    80 % bound, :data:`WITHIN_BOUND`), their mean square less ``σ²_b`` and the plots' own
    sampling variance (``plot_noise``, from their trees), over the stand's number of plots.
    A stand without a plot, or ``σ²_b`` = 0, keeps the model's figure.

    Returns ``effect``, ``weight`` (γ), ``plots`` (per stand) and ``mse``: the variance of
    the corrected stand's departure from the truth, ``(1 - γ)² · s2_stand + γ² · D``
    (``s2_stand`` without a plot)."""
    resid = np.asarray(resid, float)
    stand = np.asarray(plot_stand)
    ok = (stand >= 0) & (stand < n_stands) & np.isfinite(resid)
    ebar, k = plot_means(resid, stand, n_stands)
    dof = max(int(ok.sum()) - int((k > 0).sum()), 0)
    s2 = max(float(s2_stand), 0.0)
    sb = s2 if s2_weight is None else max(float(s2_weight), 0.0)
    within = float(np.mean(resid[ok] ** 2)) - sb if ok.any() else 0.0
    if dof:
        # the spread within the stands, at its upper 80 % bound: a test that found the stands
        # to differ found it most often where that spread came out small by chance
        from scipy import stats

        spread = float(np.sum((resid[ok] - ebar[stand[ok]]) ** 2)) / dof
        within = max(within, spread * dof / float(stats.chi2.ppf(WITHIN_BOUND, dof)))
    v = np.full(n_stands, max(within, 0.0))
    if plot_noise is not None:  # the plots' own sampling variance, from their trees
        noise = np.asarray(plot_noise, float)
        fin = ok & np.isfinite(noise)
        kn = np.bincount(stand[fin], minlength=n_stands)[:n_stands]
        vn = np.bincount(stand[fin], weights=noise[fin], minlength=n_stands)[:n_stands]
        v = np.maximum(v, vn / np.maximum(kn, 1))
    d = v / np.maximum(k, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        g = np.where((k > 0) & (sb > 0), sb / (sb + d), 0.0)
    g = np.nan_to_num(g)
    return {"effect": g * ebar, "weight": g, "plots": k.astype(int),
            "mse": np.where(k > 0, (1 - g) ** 2 * s2 + g ** 2 * d, s2)}


def aba_stands(model: AbaModel, plot_metrics: dict, y, cell_metrics: dict, cell_stand,
               n_stands: int, plot_stand, *, plot_noise=None, resamples: int = BOOTSTRAP,
               seed: int = 0, reselect: bool = True, stand_effect: bool = True) -> dict:
    """Each stand's mean of the cell predictions and its 95 % interval (module doc).
    ``reselect``: each bootstrap resample chooses its model again (:func:`select_model` on
    its distinct plots) before it is refitted, so the interval holds the choice's
    uncertainty too (a model chosen on 8 plots is one of several nearly as good).

    The plots' residuals behind the stands' departure and the cells' variance are those of
    :func:`nested_loo` (with ``reselect``): the chosen model's own leave-one-out residuals
    understate its error.

    With a ``loglog`` model the departures and residuals are taken in proportion to the
    model's figure (its errors are), with a ``linear`` one in the figure's unit.

    Returns ``estimate``, ``low``, ``high``, ``se``, ``cells`` (per stand), ``sigma2_stand``
    (in the unit ``departures`` says: ``relative`` (a share, squared) or the figure's),
    ``procedure_loo_rmse_pct`` (the RMSE of those residuals, % of the plots' mean),
    ``resamples`` (the bootstrap refits that succeeded), ``resamples_chose`` (those that chose
    the model again: under half, the chosen model is refitted on every resample too and each
    stand takes the wider of the two variances)."""
    y = np.asarray(y, float)
    n, p = y.size, len(model.predictors)
    cell_stand = CellShares.of(cell_stand)
    Xc = model.design(cell_metrics)
    valid = np.isfinite(Xc).all(axis=1)
    # no cell holds less than nothing: a linear model below its plots' heights (a young stand
    # without a plot) would go negative
    synth, cells = cell_stand.means(np.where(valid, np.maximum(model.predict(cell_metrics),
                                                               0.0), np.nan), n_stands)
    resid = y - model.stats["loo"]
    if reselect:  # the whole procedure's leave-one-out residuals, the choice included
        nested = y - np.maximum(nested_loo(plot_metrics, y, model.target), 0.0)
        resid = np.where(np.isfinite(nested), nested, resid)
    procedure_rmse = 100 * float(np.sqrt(np.mean(resid ** 2)) / np.mean(y))
    # a loglog model's errors are in proportion to its figure (ln Y = ... + e), and so are
    # the departures and residuals taken here: a stand of 100 m³/ha does not take the error
    # of one of 500. A linear model's are in m³/ha
    rel = model.form == "loglog"
    floor = 1e-3 * float(np.mean(y))
    scale = np.maximum(model.stats["fitted"], floor) if rel else np.ones(n)
    sscale = synth if rel else np.ones(n_stands)
    resid = resid / scale
    noise = None if plot_noise is None else np.asarray(plot_noise, float) / scale ** 2
    fres = (y - model.stats["fitted"]) / scale
    s2_b = stand_variance(resid, plot_stand, noise)
    fx = _stand_correction(fres, plot_stand, n_stands, s2_b, noise, stand_effect)
    gw = fx["weight"]
    effect = fx["effect"] * sscale
    est = np.maximum(synth + effect, 0.0)
    rng = np.random.default_rng(seed)
    designs = {}

    def design(m):  # the plots' and the cells' design of a model's metrics and form, once
        key = (m.form, tuple(m.predictors))
        if key not in designs:
            xc = m.design(cell_metrics)
            designs[key] = (m.design(plot_metrics), xc, np.isfinite(xc).all(axis=1))
        return designs[key]

    def draws(reselect):
        out = []
        for _ in range(resamples):
            rep = one(rng.integers(0, n, n), reselect)
            if rep is not None:
                out.append(rep)
        return out

    def one(idx, reselect):
        m = model
        if reselect:
            u = np.unique(idx)
            if u.size < MIN_PLOTS:
                return None
            try:
                m = select_model({k: np.asarray(v)[u] for k, v in plot_metrics.items()},
                                 y[u], model.target)[0]
            except InputError:
                return None
        q = len(m.predictors)
        if np.unique(idx).size < q + 2:  # too few distinct plots to refit the model
            return None
        Xp, Xr, ok = design(m)
        yt = np.log(y) if m.form == "loglog" else y
        r = _ols(Xp[idx], yt[idx])
        if r is None:
            return None
        coef = r[0]
        s2 = float(np.sum((yt[idx] - r[1]) ** 2) / max(n - q - 1, 1))
        eta = Xr[ok] @ coef
        pred = np.full(Xr.shape[0], np.nan)
        with np.errstate(over="ignore"):
            pred[ok] = np.exp(eta + s2 / 2) if m.form == "loglog" else np.maximum(eta, 0.0)
        rep = cell_stand.means(pred, n_stands)[0]
        if gw.any():  # the resample's model corrected by the stand's own plots, as above
            with np.errstate(over="ignore"):
                fp = Xp @ coef
                fp = np.exp(fp + s2 / 2) if m.form == "loglog" else fp
            if rel:
                fp = np.maximum(fp, floor)
                rep = rep * (1 + gw * plot_means((y - fp) / fp, plot_stand, n_stands)[0])
            else:
                rep = rep + gw * plot_means(y - fp, plot_stand, n_stands)[0]
        return rep

    reps = draws(reselect)
    chose = len(reps)
    factor = n / max(n - p - 1, 1)
    v_boot = boot_variance(reps, n_stands) * factor
    if reselect and len(reps) < resamples / 2:
        # few resamples hold the plots a choice needs (5 plots: 4 in 100), and those few are
        # nearly the same plots: their spread may say nothing. The chosen model refitted on
        # every resample too, and the wider of the two taken
        fixed = draws(False)
        v_fixed = boot_variance(fixed, n_stands) * factor
        if not np.nansum(v_boot) >= np.nansum(v_fixed):
            reps = fixed
        v_boot = np.fmax(v_boot, v_fixed)
    s2_cells = float(np.mean(resid ** 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        indep = (fx["mse"] + s2_cells / np.maximum(cells, 1)) * sscale ** 2
    se = np.sqrt(v_boot + indep)
    t = t975(n - p - 1)
    return {"estimate": est, "low": np.maximum(est - t * se, 0.0), "high": est + t * se,
            "se": se, "cells": cells, "sigma2_stand": s2_b,
            "departures": "relative" if rel else "m³/ha", "resamples": len(reps),
            "resamples_chose": chose if reselect else 0, "procedure_loo_rmse_pct": procedure_rmse,
            "synthetic": synth, "stand_effect": effect, "plots_weight": gw,
            "stand_test": stand_test(fres, plot_stand),
            "joint": {"reps": reps, "factor": factor, "indep_var": indep, "t": t}}


def total_interval(est: dict, area_ha) -> dict:
    """The stands' total (m³, the stands with a figure) and its 95 % interval, from an
    :func:`aba_stands` or :func:`ratio_stands` result: the spread of the bootstrap's totals
    (one model refit moves every stand together, so the stands' errors do not cancel) plus
    each stand's own departure and cell variance, independent between stands. Returns
    ``total``, ``low``, ``high``, ``se``."""
    a, e = np.asarray(area_ha, float), np.asarray(est["estimate"], float)
    ok = np.isfinite(e)
    total = float(np.sum(a[ok] * e[ok]))
    j = est["joint"]
    tb = np.asarray(j["reps"], float).reshape(-1, e.size)[:, ok] @ a[ok]
    v_boot = float(boot_variance(tb[np.isfinite(tb)][:, None], 1)[0]) * j["factor"]
    se = float(np.sqrt(v_boot + np.sum(a[ok] ** 2 * np.asarray(j["indep_var"], float)[ok])))
    return {"total": total, "low": max(total - j["t"] * se, 0.0), "high": total + j["t"] * se,
            "se": se}


def fit_dap_height(dap, ht) -> tuple:
    """``ln DAP = a + b ln HT`` on the field trees: ``(a, b, s2, n)`` (DAP of a tree of
    height ``h``: ``exp(a + b ln h + s2 / 2)``)."""
    ok = np.isfinite(dap) & np.isfinite(ht) & (dap > 0) & (ht > 1.3)
    if ok.sum() < 5:
        raise InputError(f"-trees_table: {int(ok.sum())} trees with DAP and HT; the tree "
                         "approach needs at least 5 to relate DAP to height")
    X = np.column_stack([np.ones(ok.sum()), np.log(ht[ok])])
    y = np.log(dap[ok])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    s2 = float(np.sum((y - X @ coef) ** 2) / max(ok.sum() - 2, 1))
    return float(coef[0]), float(coef[1]), s2, int(ok.sum())


def ratio_stands(field_v, lidar_v, stand_lidar_v, plot_stand, *, plot_noise=None,
                 resamples: int = BOOTSTRAP, seed: int = 0, stand_effect: bool = True) -> dict:
    """Tree approach: each stand's detected trees' volume per ha times the ratio ``R = Σ
    field / Σ detected`` over the plots (missed trees and the DAP model's bias), with the
    interval of :func:`aba_stands` (bootstrap of R over the plots, between-stand variance of
    the plots' residuals ``field - R · detected``)."""
    f, d = np.asarray(field_v, float), np.asarray(lidar_v, float)
    n = f.size
    if d.sum() <= 0:
        raise InputError("PLOTS: no detected tree inside any plot; the tree approach needs "
                         "the plots' detected trees")
    R = f.sum() / d.sum()
    sv = np.asarray(stand_lidar_v, float)
    synth = R * sv
    # leave-one-out ratio predictions of each plot
    loo = np.array([(f.sum() - f[i]) / max(d.sum() - d[i], 1e-9) * d[i] for i in range(n)])
    resid = f - loo
    s2_b = stand_variance(resid, plot_stand, plot_noise)
    fx = _stand_correction(f - R * d, plot_stand, sv.size, s2_b, plot_noise, stand_effect)
    gw = fx["weight"]
    est = np.maximum(synth + fx["effect"], 0.0)
    # the stands' figures over resamples of the plots: R again, and each stand corrected by
    # its own plots' residuals from that R (as :func:`aba_stands`)
    rng = np.random.default_rng(seed)
    reps = []
    for _ in range(resamples):
        idx = rng.integers(0, n, n)
        if d[idx].sum() > 0:
            rb = f[idx].sum() / d[idx].sum()
            reps.append(rb * sv + gw * plot_means(f - rb * d, plot_stand, sv.size)[0])
    v_r = boot_variance(np.array(reps), sv.size) if reps else np.full(sv.size, np.nan)
    with np.errstate(invalid="ignore"):
        se = np.sqrt(v_r * n / max(n - 1, 1) + fx["mse"])
    t = t975(n - 1)
    return {"estimate": est, "low": np.maximum(est - t * se, 0), "high": est + t * se, "se": se,
            "ratio": float(R), "loo": loo, "sigma2_stand": s2_b, "synthetic": synth,
            "stand_effect": fx["effect"], "plots_weight": gw,
            "stand_test": stand_test(f - R * d, plot_stand),
            "joint": {"reps": reps, "factor": n / max(n - 1, 1), "indep_var": fx["mse"],
                      "t": t},
            **{f"plot_{k}": v for k, v in fit_stats(f, R * d, loo, 1).items()}}

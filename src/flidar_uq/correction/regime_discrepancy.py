"""The model's systematic error shared within a regime, learnt on the reference period.

A description of the buoy's motion that is 5 % off for 4-7 s seas is 5 % off for every such
record: its error does not average out over the records of a bin, as the records' own errors
do. The record model's intervals carry the global parameters' uncertainty, not such an error.
This module measures it where a reference covers the regime and carries it into every bin
statistic (docs/inference.md, "Regime discrepancy"):

1. Regimes. A regime is a 1-m/s speed bin crossed with the wave-period class of the
   record's measured tilt period (< 4 s, 4-7 s, > 7 s; :data:`PERIOD_EDGES_S`), all heights
   together.
2. Residuals. Each regime's residual on each day is ``log(mean TI_corrected / mean
   TI_reference)`` over the day's reference records of the regime (the reference's TI at the
   point, a fixed lidar's divided by its std ratio ``g``): a ratio of means, because the log
   of each record's ratio has a mean of its own (half the records' noise variance). Each
   regime's mean over its days is smoothed with its neighbours in speed (weights 1/4, 1/2,
   1/4 over the 1-m/s bins of its period class), and its noise is measured from whole days:
   the variance of the day values over the number of days, so that the records of a day,
   which share their weather, count once.
3. Discrepancy. The regimes' smoothed means are a normal population ``N(mu, tau^2)`` seen
   with that noise, the hierarchical normal model of Gelman et al. (2013, Sec. 5.4)
   (:func:`flidar_uq.correction.bin_population.tau_posterior`): each regime's discrepancy is
   its mean shrunk towards ``mu`` by its noise, with its posterior sd; a regime that no
   reference record covers takes ``N(mu, tau^2)``, the spread of the regimes the reference
   did cover.
4. Blocked cross-validation. The days are split into :data:`CV_FOLDS` folds; each fold's
   regime means are predicted from the other folds' discrepancy (or by 0 without it) and
   scored by their predictive log density. The term is kept only when it raises the
   expected log predictive density by more than twice its standard error; otherwise the
   bin statistics carry none.

The bin statistics then divide each record's population draw by ``exp(delta)`` of its
regime (one draw of every regime's discrepancy per posterior draw, shared by the regime's
records). The per-record corrected TI is the record model's own.

Without reference records (``reference.kind: none``, or a reference that covers fewer than
:data:`MIN_REGIMES` regimes) nothing can be learnt, and the model's systematic error is carried as a prior
(:func:`prior_discrepancy`): ``N(0, prior_sd^2)`` on log TI, one draw per posterior draw
shared by every record, with ``prior_sd`` the sd of the model's regime error measured on
the project's virtual scenarios (:data:`REGIME_DISCREPANCY_PRIOR_SD`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from flidar_uq.correction.bin_population import tau_posterior
from flidar_uq.data.binning import speed_bin_ms

__all__ = [
    "CV_FOLDS",
    "MIN_REGIMES",
    "PERIOD_EDGES_S",
    "RegimeDiscrepancy",
    "REGIME_DISCREPANCY_PRIOR_SD",
    "fit_regime_discrepancy",
    "prior_discrepancy",
    "regime_keys",
]

#: Edges of the wave-period classes of the record's tilt period (s): < 4, 4-7, > 7 s.
PERIOD_EDGES_S = (4.0, 7.0)
#: Folds of whole days of the blocked cross-validation (step 4).
CV_FOLDS = 5
#: Fewest reference records of a regime for its mean to enter the fit.
MIN_REGIME_RECORDS = 10
#: Fewest regimes with :data:`MIN_REGIME_RECORDS` for the discrepancy to be learnt.
MIN_REGIMES = 3
#: Prior sd of the regime discrepancy without reference records (-, log TI): the largest
#: sd of the model's regime error measured on the virtual scenarios, the wave followers'
#: 0.007 (``benchmarks/bin_statistics.py``; docs/inference.md, "Regime discrepancy").
REGIME_DISCREPANCY_PRIOR_SD = 0.007
#: Weights of a regime and its two neighbours in speed (step 2).
_SMOOTH = (0.25, 0.5, 0.25)


@dataclass(frozen=True)
class RegimeDiscrepancy:
    """The regime discrepancy of a campaign (:func:`fit_regime_discrepancy`).

    Attributes
    ----------
    regimes : pandas.DataFrame
        One row per regime seen in the campaign: ``hws_bin_ms`` (m/s), ``period_class``,
        ``n_reference`` (reference records), ``residual`` (smoothed mean log residual, -),
        ``noise_sd`` (its sd from whole days, -), ``delta`` and ``delta_sd`` (the
        discrepancy's posterior mean and sd on log TI, -; ``mu`` and ``tau`` for a regime
        without reference).
    tau : float
        Posterior mean of the regimes' spread (-, log TI).
    kept : bool
        Whether blocked cross-validation keeps the term (step 4); when False the bin
        statistics carry none.
    elpd_gain : float
        Gain of the expected log predictive density of the held-out folds' regime means
        with the term over without it (nats), and ``elpd_gain_se`` its standard error.
    reason : str
        One line: why the term is kept or not.
    """

    regimes: pd.DataFrame
    tau: float
    kept: bool
    elpd_gain: float
    elpd_gain_se: float
    reason: str

    def draws(self, keys: pd.DataFrame, ndraws: int, rng: np.random.Generator):
        """The discrepancy of each record's regime: ``(regime index per record (n,),
        draws (ndraws, n_regimes))`` (-, log TI), or None when the term is not kept.
        ``keys`` (:func:`regime_keys` of the records) holds ``hws_bin_ms`` and
        ``period_class``; a record whose regime the campaign did not see, or without a
        key, takes the spread of the regimes (``mu``, ``tau``)."""
        if not self.kept:
            return None
        table = self.regimes.set_index(["hws_bin_ms", "period_class"])
        mu, tau = float(self.regimes.attrs["mu"]), self.tau
        index = pd.MultiIndex.from_frame(keys[["hws_bin_ms", "period_class"]])
        at = table.index.get_indexer(index)
        unseen = at < 0
        at[unseen] = len(table)  # one more column: the population of regimes
        mean = np.append(table["delta"].to_numpy(dtype=float), mu)
        sd = np.append(table["delta_sd"].to_numpy(dtype=float), tau)
        z = rng.standard_normal((ndraws, mean.size))
        return at, mean[None, :] + sd[None, :] * z


def prior_discrepancy(prior_sd: float, why: str) -> RegimeDiscrepancy:
    """The regime discrepancy without reference records: its prior.

    ``N(0, prior_sd^2)`` on log TI, one draw shared by every regime (no regime is seen:
    every record takes the column of unseen regimes), carried whenever ``prior_sd > 0``.

    Parameters
    ----------
    prior_sd : float
        Prior sd of the discrepancy (-, log TI; config ``reference.
        regime_discrepancy_prior_sd``, default :data:`REGIME_DISCREPANCY_PRIOR_SD`).
    why : str
        Why no discrepancy is learnt (the start of ``reason``).

    Returns
    -------
    RegimeDiscrepancy
        No regime rows, ``mu = 0``, ``tau = prior_sd``.
    """
    if not (np.isfinite(prior_sd) and prior_sd >= 0.0):
        raise ValueError(f"prior_discrepancy: prior_sd={prior_sd} must be finite and >= 0")
    columns = ["hws_bin_ms", "period_class", "n_reference", "residual", "noise_sd", "delta"]
    table = pd.DataFrame(columns=[*columns, "delta_sd"])
    table.attrs["mu"] = 0.0
    kept = prior_sd > 0.0
    reason = f"{why}: the prior sd {prior_sd:g} of the regime discrepancy" + (
        " is carried" if kept else ", 0: none carried"
    )
    return RegimeDiscrepancy(table, float(prior_sd), kept, 0.0, 0.0, reason)


def regime_keys(records: pd.DataFrame) -> pd.DataFrame:
    """The regime of each record (step 2): ``hws_bin_ms`` (the record's 1-m/s speed bin,
    m/s) and ``period_class`` (``"< 4 s"``, ``"4-7 s"``, ``"> 7 s"`` of the mean of
    ``roll_period_s`` and ``pitch_period_s``; ``""`` without them), index of ``records``."""
    n = len(records)
    periods = [
        records[c].to_numpy(dtype=float) if c in records else np.full(n, np.nan)
        for c in ("roll_period_s", "pitch_period_s")
    ]
    stacked = np.vstack(periods)
    count = np.sum(np.isfinite(stacked), axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        period = np.nansum(stacked, axis=0) / count
    lo, hi = PERIOD_EDGES_S
    label = np.where(
        period < lo, f"< {lo:g} s", np.where(period <= hi, f"{lo:g}-{hi:g} s", f"> {hi:g} s")
    )
    label = np.where(np.isfinite(period), label, "")
    hws = records["hws_mean_ms"].to_numpy(dtype=float)
    return pd.DataFrame(
        {"hws_bin_ms": speed_bin_ms(hws), "period_class": label}, index=records.index
    )


def _regime_means(
    corrected: np.ndarray, reference: np.ndarray, keys: pd.DataFrame, day: np.ndarray
) -> pd.DataFrame:
    """Per regime: reference records, mean of its day residuals smoothed over its speed
    neighbours, and that mean's variance from the day residuals (steps 1-2)."""
    frame = keys.assign(c=corrected, ref=reference, day=day)
    sums = frame.groupby(["hws_bin_ms", "period_class", "day"], sort=True)[["c", "ref"]].sum()
    days = np.log(sums["c"] / sums["ref"]).rename("r")
    per = days.groupby(level=[0, 1]).agg(["mean", "var", "count"])
    per["n_reference"] = frame.groupby(["hws_bin_ms", "period_class"])["c"].size()
    per = per.reset_index()
    # a regime seen on one or two days: the campaign's within-day scatter of day means
    pooled = float(np.nanmedian(per["var"])) if per["var"].notna().any() else np.nan
    var = np.where(per["count"] >= 3, per["var"], pooled)
    per["var_mean"] = var / per["count"]
    out = []
    for _, cls in per.groupby("period_class", sort=True):
        cls = cls.sort_values("hws_bin_ms")
        x, v = cls["mean"].to_numpy(), cls["var_mean"].to_numpy()
        bins = cls["hws_bin_ms"].to_numpy()
        sm, sv = np.empty_like(x), np.empty_like(v)
        for k in range(x.size):
            near = np.abs(bins - bins[k]) <= 1.0 + 1e-9
            w = np.where(bins[near] == bins[k], _SMOOTH[1], _SMOOTH[0])
            w = w / w.sum()
            sm[k] = np.sum(w * x[near])
            sv[k] = np.sum(w**2 * v[near])
        out.append(cls.assign(residual=sm, noise_var=sv))
    return pd.concat(out, ignore_index=True) if out else per.assign(residual=[], noise_var=[])


def _shrink(y: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Posterior mean and sd of each regime's discrepancy, ``mu`` and the posterior mean of
    ``tau`` (step 3), ``tau`` integrated over its grid posterior."""
    grid, mass = tau_posterior(y, v)
    w = 1.0 / (v[None, :] + grid[:, None] ** 2)
    v_mu = 1.0 / w.sum(axis=1)
    mu = (w * y[None, :]).sum(axis=1) * v_mu
    prec = 1.0 / v[None, :] + 1.0 / grid[:, None] ** 2
    m = (y[None, :] / v[None, :] + mu[:, None] / grid[:, None] ** 2) / prec
    var = 1.0 / prec + (v[None, :] / (v[None, :] + grid[:, None] ** 2)) ** 2 * v_mu[:, None]
    mean = mass @ m
    second = mass @ (var + m**2)
    return mean, np.sqrt(np.maximum(second - mean**2, 0.0)), float(mass @ mu), float(mass @ grid)


def fit_regime_discrepancy(
    ti_corrected, ti_reference, keys: pd.DataFrame, day
) -> RegimeDiscrepancy:
    """The regime discrepancy from the reference records (steps 1-4).

    Parameters
    ----------
    ti_corrected, ti_reference : numpy.ndarray, shape (n,)
        Each record's corrected TI (its posterior median) and the reference's TI at the
        point (-); records where either is not finite and positive are left out.
    keys : pandas.DataFrame
        :func:`regime_keys` of the same records.
    day : numpy.ndarray, shape (n,)
        The record's day (any hashable label, e.g. the UTC date): the blocks of the noise
        and of the cross-validation.

    Returns
    -------
    RegimeDiscrepancy
    """
    c = np.asarray(ti_corrected, dtype=float)
    ref = np.asarray(ti_reference, dtype=float)
    keys = keys.reset_index(drop=True)
    day = np.asarray(day)
    if not (c.size == ref.size == len(keys) == day.size):
        raise ValueError(
            f"fit_regime_discrepancy: {c.size} corrected, {ref.size} reference TI, "
            f"{len(keys)} keys and {day.size} days do not match"
        )
    with np.errstate(invalid="ignore"):
        ok = (c > 0) & (ref > 0) & np.isfinite(c) & np.isfinite(ref)
    ok &= (keys["period_class"].to_numpy() != "") & keys["hws_bin_ms"].notna().to_numpy()
    c, ref, keys, day = c[ok], ref[ok], keys[ok].reset_index(drop=True), day[ok]
    empty = pd.DataFrame(
        columns=["hws_bin_ms", "period_class", "n_reference", "residual", "noise_sd"]
    )
    per = _regime_means(c, ref, keys, day) if c.size else empty
    fit = per[per["n_reference"] >= MIN_REGIME_RECORDS] if len(per) else per
    if len(fit) < MIN_REGIMES or not np.all(fit["noise_var"] > 0):
        reason = f"{len(fit)} regimes with >= {MIN_REGIME_RECORDS} reference records: too few"
        table = fit.assign(delta=0.0, delta_sd=0.0, noise_sd=np.sqrt(fit.get("noise_var", 0.0)))
        table.attrs["mu"] = 0.0
        return RegimeDiscrepancy(table, 0.0, False, 0.0, 0.0, reason)
    y, v = fit["residual"].to_numpy(dtype=float), fit["noise_var"].to_numpy(dtype=float)
    delta, delta_sd, mu, tau = _shrink(y, v)
    gain, se = _blocked_cv(c, ref, keys, day)
    kept = gain > 2.0 * se
    reason = (
        f"blocked cross-validation over whole days ({CV_FOLDS} folds): the term "
        f"{'raises' if gain > 0 else 'lowers'} the held-out elpd by {gain:.1f} "
        f"(se {se:.1f}) nats, {'kept' if kept else 'not kept (not above 2 se)'}"
    )
    columns = ["hws_bin_ms", "period_class", "n_reference", "residual"]
    table = fit[columns].assign(noise_sd=np.sqrt(v), delta=delta, delta_sd=delta_sd)
    table.attrs["mu"] = mu
    return RegimeDiscrepancy(table.reset_index(drop=True), tau, kept, gain, se, reason)


def _blocked_cv(c, ref, keys: pd.DataFrame, day: np.ndarray) -> tuple[float, float]:
    """Expected log predictive density gain (and its se over held-out regimes) of the held-out
    folds' regime means with the discrepancy over without it (step 4)."""
    days = np.unique(day)
    fold_of_day = {d: k % CV_FOLDS for k, d in enumerate(days)}
    fold = np.array([fold_of_day[d] for d in day])
    gains = []
    for k in range(CV_FOLDS):
        train, test = fold != k, fold == k
        if not test.any() or not train.any():
            continue
        tr = _regime_means(c[train], ref[train], keys[train].reset_index(drop=True), day[train])
        tr = tr[(tr["n_reference"] >= MIN_REGIME_RECORDS) & (tr["noise_var"] > 0)]
        te = _regime_means(c[test], ref[test], keys[test].reset_index(drop=True), day[test])
        te = te[(te["n_reference"] >= MIN_REGIME_RECORDS) & (te["noise_var"] > 0)]
        if len(tr) < 3 or te.empty:
            continue
        y, v = tr["residual"].to_numpy(float), tr["noise_var"].to_numpy(float)
        delta, delta_sd, mu, tau = _shrink(y, v)
        pred = tr.assign(delta=delta, delta_sd=delta_sd).set_index(["hws_bin_ms", "period_class"])
        idx = pd.MultiIndex.from_frame(te[["hws_bin_ms", "period_class"]])
        at = pred.index.get_indexer(idx)
        m = np.where(at >= 0, pred["delta"].to_numpy()[at], mu)
        s = np.where(at >= 0, pred["delta_sd"].to_numpy()[at], tau)
        x, nv = te["residual"].to_numpy(float), te["noise_var"].to_numpy(float)
        with_term = -0.5 * (np.log(2 * np.pi * (nv + s**2)) + (x - m) ** 2 / (nv + s**2))
        without = -0.5 * (np.log(2 * np.pi * nv) + x**2 / nv)
        gains.append(with_term - without)
    if not gains:
        return 0.0, 0.0
    g = np.concatenate(gains)
    return float(g.sum()), float(np.sqrt(g.size) * g.std(ddof=1)) if g.size > 1 else 0.0

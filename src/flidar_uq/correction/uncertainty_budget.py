"""Uncertainty budget of the corrected TI: which source makes how much of an interval.

Method ("hold one source at its median", a one-at-a-time variance reduction): the
posterior draws are propagated once with every source free
(:func:`flidar_uq.correction.propagation.draw_corrected_ti`) and once per source with that
source held at its posterior median (:func:`~flidar_uq.correction.propagation.draw_held_ti`), with the same random numbers (common
random numbers: the runs differ only by the held source). For a statistic ``Y`` (the mean
corrected TI of a height over the campaign, or of one speed bin) the share of source ``k``
is

    share_k = 1 - Var(Y | k held) / Var(Y),

the fraction of the posterior variance that would go if ``k`` were known exactly. The
global parameters of the other sources are conditioned on the held value (Gaussian
approximation of their joint posterior), so that a source's share includes what the
parameters correlated with it (e.g. the motion scale, which compensates rho in the fit)
would lose with it. For a statistic linear in independent sources the shares are the
first-order Sobol indices and sum to 1; otherwise they need not: correlated sources explain
the same part of the variance (the sum exceeds 1) and interactions make it fall short. The
table gives the remainder ``1 - sum`` so that this is seen, and the interval width with each
source held.

The sources are :data:`flidar_uq.correction.propagation.UNCERTAINTY_SOURCES`: the motion
description (sigma_Z), rho, the noise model (kappa, tau0), the reference's response to
turbulence (the record-to-record scatter of the lidar-to-point std ratio g), and the
sampling of the measured 10-min std.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from flidar_uq.correction.propagation import UNCERTAINTY_SOURCES
from flidar_uq.progress import ProgressLog

__all__ = ["BUDGET_SOURCES", "uncertainty_budget"]

#: The budget's sources: the propagation's (:data:`UNCERTAINTY_SOURCES`) and the regime
#: discrepancy of the bin statistics (:mod:`flidar_uq.correction.regime_discrepancy`).
BUDGET_SOURCES = (*UNCERTAINTY_SOURCES, "regime_discrepancy")

log = logging.getLogger(__name__)


def _group_mean_draws(ti_draws: np.ndarray, codes: np.ndarray, ngroups: int) -> np.ndarray:
    """Mean over each group's records per draw, in float64: shape (ndraws, ngroups)."""
    out = np.full((ti_draws.shape[0], ngroups), np.nan)
    for g in range(ngroups):
        cols = codes == g
        if cols.any():
            out[:, g] = ti_draws[:, cols].mean(axis=1, dtype=np.float64)
    return out


def uncertainty_budget(
    draws_for: Callable[[tuple[str, ...]], np.ndarray],
    keys: Mapping[str, pd.DataFrame],
    usable,
    *,
    sources: Sequence[str] = UNCERTAINTY_SOURCES,
    credible_mass: float = 0.9,
    min_count: int = 2,
) -> pd.DataFrame:
    """Variance shares of the mean corrected TI per group from held-source reruns.

    Parameters
    ----------
    draws_for : callable
        ``draws_for(hold)`` returns the corrected TI draws (-), shape (ndraws, n_records),
        float32 (as ``CorrectedDraws.ti`` holds them; the group means are summed in float64)
        or float64,
        with the sources in ``hold`` held at their median and the same random numbers for
        every ``hold`` (e.g. ``.ti`` of :func:`flidar_uq.correction.propagation.draw_held_ti`
        with a fixed seed). Called once with ``()`` and once per
        source; each result is reduced to group means at once (memory of one draw matrix).
    keys : mapping of str -> pandas.DataFrame
        Groupings: name -> group key columns, one row per record (e.g. ``"campaign"``:
        ``height_m`` alone, the campaign mean of each height; ``"speed bin"``:
        ``height_m, hws_bin_ms``); NaN keys are left out.
    usable : array_like of bool, shape (n_records,)
        Records entering the statistic (converged, finite draws).
    sources : sequence of str
        The sources to hold, one at a time (default all of ``UNCERTAINTY_SOURCES``).
    credible_mass : float
        Mass of the equal-tailed intervals whose widths are reported.
    min_count : int
        Fewest usable records for a group's row.

    Returns
    -------
    pandas.DataFrame
        One row per group: ``grouping``, the key columns, ``n``, ``ti_mean`` (posterior
        median of the group mean), ``width`` (its interval width, -), ``sd`` (posterior std,
        -), per source ``share_<source>`` (``1 - Var(held) / Var(all)``) and
        ``width_<source>`` (interval width with it held), and ``remainder``
        (``1 - sum of shares``: interactions and correlated sources).

    Raises
    ------
    ValueError
        If a source is unknown or the shapes do not match.
    """
    unknown = [k for k in sources if k not in BUDGET_SOURCES]
    if unknown:
        raise ValueError(
            f"uncertainty_budget: unknown sources {unknown}; known: {list(BUDGET_SOURCES)}"
        )
    usable = np.asarray(usable, dtype=bool)
    tables = {}
    for name, kv in keys.items():
        if len(kv) != usable.size:
            raise ValueError(
                f"uncertainty_budget: {len(kv)} key rows of {name!r} for {usable.size} records"
            )
        kv = kv.reset_index(drop=True)
        valid = kv.notna().all(axis=1).to_numpy() & usable
        groups = kv[valid].drop_duplicates().sort_values(list(kv.columns)).reset_index(drop=True)
        codes = np.full(len(kv), -1)
        merged = kv[valid].merge(groups.reset_index(), on=list(kv.columns), how="left")
        codes[valid] = merged["index"].to_numpy()
        tables[name] = (groups, codes)
    q = [(1.0 - credible_mass) / 2.0, (1.0 + credible_mass) / 2.0]

    def reduce(hold):
        d = np.asarray(draws_for(hold))  # float32 draws stay float32 (summed in float64)
        if d.dtype.kind != "f":
            d = d.astype(float)
        if d.ndim != 2 or d.shape[1] != usable.size:
            raise ValueError(
                f"uncertainty_budget: draws for hold={list(hold)} have shape {d.shape}, "
                f"expected (ndraws, {usable.size})"
            )
        return {n: _group_mean_draws(d, c, len(g)) for n, (g, c) in tables.items()}

    def width(y):
        lo, hi = np.quantile(y, q, axis=0)
        return hi - lo

    # one pass with every source drawn, then one with each source held at its centre
    passes = ProgressLog(log, "uncertainty budget", 1 + len(sources), "passes", step_pct=1.0)
    y_all = reduce(())
    passes.update()
    y_held = {}
    for k in sources:
        y_held[k] = reduce((k,))
        passes.update()
    out = []
    for name, (groups, codes) in tables.items():
        t = groups.copy()
        t.insert(0, "grouping", name)
        var_all = np.var(y_all[name], axis=0, ddof=1)
        t["n"] = np.bincount(codes[codes >= 0], minlength=len(groups))
        t["ti_mean"] = np.median(y_all[name], axis=0)
        t["width"] = width(y_all[name])
        t["sd"] = np.sqrt(var_all)
        shares = []
        for k in sources:
            with np.errstate(invalid="ignore", divide="ignore"):
                share = 1.0 - np.var(y_held[k][name], axis=0, ddof=1) / var_all
            t[f"share_{k}"] = share
            t[f"width_{k}"] = width(y_held[k][name])
            shares.append(share)
        t["remainder"] = 1.0 - np.sum(shares, axis=0) if shares else np.nan
        out.append(t[t["n"] >= min_count])
    return pd.concat(out, ignore_index=True)

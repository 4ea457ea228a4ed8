"""Uncertainty budget of the corrected TI: which source makes how much of an interval.

Method ("hold one source at its median", a one-at-a-time variance reduction): the
posterior draws are propagated once with every source free
(:func:`flidar_uq.correction.propagation.corrected_ti`) and once per source with that
source held at its posterior median (``hold=``), with the same random numbers (common
random numbers: the runs differ only by the held source). For a statistic ``Y`` (the mean
corrected TI of a height over the campaign, or of one speed bin) the share of source ``k``
is

    share_k = 1 - Var(Y | k held) / Var(Y),

the fraction of the posterior variance that would go if ``k`` were known exactly. For a
statistic linear in independent sources the shares are the first-order Sobol indices and
sum to 1; otherwise they need not: interactions between sources make the sum exceed or fall
short of 1, and posterior correlation between sources (e.g. rho against the motion scale,
which compensate each other in the fit) can make a share negative (holding one source
removes the compensation). The table gives the remainder ``1 - sum`` so that this is seen,
and the interval width with each source held.

The sources are :data:`flidar_uq.correction.propagation.UNCERTAINTY_SOURCES`: the motion
description (sigma_Z), rho, the noise model (kappa, tau0), the reference's response to
turbulence (the record-to-record scatter of the lidar-to-point std ratio g), and the
sampling of the measured 10-min std.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from flidar_uq.correction.propagation import UNCERTAINTY_SOURCES

__all__ = ["uncertainty_budget"]


def _group_mean_draws(ti_draws: np.ndarray, codes: np.ndarray, ngroups: int) -> np.ndarray:
    """Mean over each group's records per draw: shape (ndraws, ngroups)."""
    out = np.full((ti_draws.shape[0], ngroups), np.nan)
    for g in range(ngroups):
        cols = codes == g
        if cols.any():
            out[:, g] = ti_draws[:, cols].mean(axis=1)
    return out


def uncertainty_budget(
    ti_draws: Mapping[str, np.ndarray],
    keys: pd.DataFrame,
    usable,
    *,
    credible_mass: float = 0.9,
    min_count: int = 2,
) -> pd.DataFrame:
    """Variance shares of the mean corrected TI per group from held-source reruns.

    Parameters
    ----------
    ti_draws : mapping of str -> numpy.ndarray, shape (ndraws, n_records)
        Corrected TI draws (-): ``"all"`` with every source free and one entry per held
        source (names from ``UNCERTAINTY_SOURCES``), all from the same seed.
    keys : pandas.DataFrame
        Group key columns, one row per record (e.g. ``height_m`` alone for the campaign
        mean of each height, or ``height_m, hws_bin_ms``); NaN keys are left out.
    usable : array_like of bool, shape (n_records,)
        Records entering the statistic (converged, finite draws).
    credible_mass : float
        Mass of the equal-tailed intervals whose widths are reported.
    min_count : int
        Fewest usable records for a group's row.

    Returns
    -------
    pandas.DataFrame
        One row per group: the key columns, ``n``, ``ti_mean`` (posterior median of the
        group mean), ``width`` (its interval width, -), ``sd`` (posterior std, -), per
        source ``share_<source>`` (``1 - Var(held) / Var(all)``) and
        ``width_<source>`` (interval width with it held), and ``remainder``
        (``1 - sum of shares``: interactions and correlated sources).

    Raises
    ------
    ValueError
        If ``"all"`` is missing, a source is unknown or the shapes do not match.
    """
    if "all" not in ti_draws:
        raise ValueError("uncertainty_budget: ti_draws needs the unheld draws under 'all'")
    sources = [k for k in ti_draws if k != "all"]
    unknown = [k for k in sources if k not in UNCERTAINTY_SOURCES]
    if unknown:
        raise ValueError(
            f"uncertainty_budget: unknown sources {unknown}; known: {list(UNCERTAINTY_SOURCES)}"
        )
    full = np.asarray(ti_draws["all"], dtype=float)
    usable = np.asarray(usable, dtype=bool)
    for k, d in ti_draws.items():
        if np.shape(d) != full.shape:
            raise ValueError(
                f"uncertainty_budget: draws of {k!r} have shape {np.shape(d)}, "
                f"'all' has {full.shape}"
            )
    if len(keys) != full.shape[1] or usable.shape != (full.shape[1],):
        raise ValueError(
            f"uncertainty_budget: {len(keys)} key rows and {usable.size} usable flags for "
            f"{full.shape[1]} records"
        )
    kv = keys.reset_index(drop=True)
    valid = kv.notna().all(axis=1).to_numpy() & usable
    groups = kv[valid].drop_duplicates().sort_values(list(kv.columns)).reset_index(drop=True)
    codes = np.full(len(kv), -1)
    codes[valid] = (
        kv[valid].merge(groups.reset_index(), on=list(kv.columns), how="left")["index"].to_numpy()
    )
    q = [(1.0 - credible_mass) / 2.0, (1.0 + credible_mass) / 2.0]

    def width(y):
        lo, hi = np.quantile(y, q, axis=0)
        return hi - lo

    y_all = _group_mean_draws(full, codes, len(groups))
    var_all = np.var(y_all, axis=0, ddof=1)
    out = groups.copy()
    out["n"] = np.bincount(codes[codes >= 0], minlength=len(groups))
    out["ti_mean"] = np.median(y_all, axis=0)
    out["width"] = width(y_all)
    out["sd"] = np.sqrt(var_all)
    shares = []
    for k in sources:
        y = _group_mean_draws(np.asarray(ti_draws[k], dtype=float), codes, len(groups))
        with np.errstate(invalid="ignore", divide="ignore"):
            share = 1.0 - np.var(y, axis=0, ddof=1) / var_all
        out[f"share_{k}"] = share
        out[f"width_{k}"] = width(y)
        shares.append(share)
    out["remainder"] = 1.0 - np.sum(shares, axis=0) if shares else np.nan
    return out[out["n"] >= min_count].reset_index(drop=True)

"""Figures of the report (matplotlib, Agg backend); each function returns a Figure.

Inputs are plain arrays / DataFrames (the pipeline's result tables); nothing is read from
disk here. Styles follow the seed 000 figures they reproduce (cited per function).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from flidar_uq.data.binning import speed_bin_ms  # noqa: E402

__all__ = [
    "IEC_TURBULENCE_CATEGORIES",
    "budget_figure",
    "calibration_figure",
    "convergence_figure",
    "iec_representative_ti",
    "posterior_figure",
    "sigma_scatter_figure",
    "ti_speed_bins_figure",
]

#: Reference turbulence intensity I_ref of the IEC 61400-1 ed. 4 (2019) turbulence
#: categories (Table 1), -.
IEC_TURBULENCE_CATEGORIES = {"A+": 0.18, "A": 0.16, "B": 0.14, "C": 0.12}


def iec_representative_ti(hws_ms, i_ref: float) -> np.ndarray:
    """Representative TI of an IEC turbulence category: ``I_ref (0.75 + 5.6 / V)``.

    The normal turbulence model of IEC 61400-1 ed. 4 (2019), Eq. (10):
    ``sigma_1 = I_ref (0.75 V_hub + b)``, ``b = 5.6 m/s``, divided by ``V_hub``.

    Parameters
    ----------
    hws_ms : array_like
        Hub-height wind speed V (m/s), > 0.
    i_ref : float
        Reference turbulence intensity of the category (-).

    Returns
    -------
    numpy.ndarray
        Representative (90 % quantile) TI (-).
    """
    v = np.asarray(hws_ms, dtype=float)
    return i_ref * (0.75 + 5.6 / v)  # Eq. (10) of IEC 61400-1 ed. 4 divided by V


def _one_to_one(ax, x, y) -> None:
    finite = np.concatenate([np.asarray(x, float), np.asarray(y, float)])
    finite = finite[np.isfinite(finite)]
    hi = float(finite.max()) * 1.05 if finite.size else 1.0
    ax.plot([0, hi], [0, hi], "k--", lw=1, label="1:1")
    ax.set_xlim(0, hi)
    ax.set_ylim(0, hi)


def sigma_scatter_figure(
    sigma_moving_ms: np.ndarray,
    sigma_ref_ms: np.ndarray,
    sigma_corr: dict[str, np.ndarray],
    *,
    ref_label: str = "reference",
) -> Figure:
    """sigma_moving against sigma_ref and the corrected stds (seed 000 Figs. 4-5 style).

    Parameters
    ----------
    sigma_moving_ms : numpy.ndarray, shape (n,)
        Floating-lidar 10-min HWS std (m/s), x axis.
    sigma_ref_ms : numpy.ndarray, shape (n,)
        Reference (or true) HWS std (m/s): left panel, blue crosses.
    sigma_corr : dict of str -> numpy.ndarray, shape (n,)
        Motion-corrected reference std per law (seed 000 Eqs. 15-17), m/s: right panel.
    ref_label : str
        Name of the reference in the axis labels.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.5), sharex=True, sharey=True)
    x = np.asarray(sigma_moving_ms, float)
    axes[0].plot(x, sigma_ref_ms, "x", color="tab:blue", ms=3, alpha=0.6, label=r"$\sigma_{ref}$")
    _one_to_one(axes[0], x, sigma_ref_ms)
    axes[0].set_title("uncorrected (Fig. 5c style)")
    axes[0].set_ylabel(rf"$\sigma_{{ref}}$ / $\sigma_{{corr}}$ ({ref_label}) [m/s]")
    markers = {"PC": ("o", "tab:red"), "U": ("s", "tab:green"), "C": ("^", "tab:purple")}
    for name, y in sigma_corr.items():
        m, c = markers.get(name, (".", "tab:gray"))
        axes[1].plot(
            x, y, m, mfc="none", color=c, ms=3, alpha=0.6, label=rf"$\sigma_{{corr}}$ {name}"
        )
    _one_to_one(
        axes[1], x, np.concatenate([np.asarray(v, float) for v in sigma_corr.values()] or [x])
    )
    axes[1].set_title("motion-corrected reference (Fig. 5d style)")
    for ax in axes:
        ax.set_xlabel(r"$\sigma_{moving}$ [m/s]")
        ax.legend(loc="upper left", fontsize=8)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def ti_speed_bins_figure(
    speed_bins: pd.DataFrame,
    records: pd.DataFrame | None = None,
    *,
    credible_mass: float,
    title: str = "",
    truth: pd.DataFrame | None = None,
) -> Figure:
    """Corrected TI per speed bin with the IEC 61400-1 categories (seed 000 Fig. 8b style).

    Parameters
    ----------
    speed_bins : pandas.DataFrame
        Rows of results/ti/speed_bins.csv of one height: ``hws_bin_ms``, ``ti_mean``,
        ``ti_mean_lo``, ``ti_mean_hi``, ``ti_rep``, ``ti_rep_lo``, ``ti_rep_hi``,
        ``ti_mean_uncorrected``, ``ti_rep_uncorrected``.
    records : pandas.DataFrame, optional
        Records of the same height (``hws_mean_ms``, ``ti_corrected_median``): drawn as
        faint points.
    credible_mass : float
        Mass of the intervals (-), for the legend.
    title : str
    truth : pandas.DataFrame, optional
        ``hws_bin_ms``, ``ti_mean``, ``ti_rep`` of the true TI per bin (virtual campaigns).

    Returns
    -------
    matplotlib.figure.Figure
        The bands are the credible intervals of the bin mean and of the bin's
        representative TI (from the draws of the bin statistic), as the legend says.
    """
    fig, ax = plt.subplots(figsize=(10.5, 4.5))
    b = speed_bins[np.isfinite(speed_bins["ti_mean"])].sort_values("hws_bin_ms")
    if records is not None and len(records):
        ax.plot(
            records["hws_mean_ms"],
            records["ti_corrected_median"],
            ".",
            color="0.75",
            ms=1.5,
            alpha=0.4,
            label="records, corrected (median)",
            zorder=1,
        )
    v = b["hws_bin_ms"].to_numpy(dtype=float)
    pct = f"{credible_mass:.0%}"
    ax.fill_between(v, b["ti_mean_lo"], b["ti_mean_hi"], color="tab:blue", alpha=0.35, zorder=2)
    ax.plot(v, b["ti_mean"], "o-", color="tab:blue", ms=3, lw=1.5, zorder=3,
            label=f"corrected bin mean, {pct} interval of the mean")  # fmt: skip
    ax.fill_between(v, b["ti_rep_lo"], b["ti_rep_hi"], color="tab:orange", alpha=0.35, zorder=2)
    ax.plot(v, b["ti_rep"], "s-", color="tab:orange", ms=3, lw=1.5, zorder=3,
            label=f"corrected representative TI, {pct} interval")  # fmt: skip
    ax.plot(v, b["ti_mean_uncorrected"], "--", color="k", lw=1, label="uncorrected bin mean")
    ax.plot(v, b["ti_rep_uncorrected"], ":", color="k", lw=1.2, label="uncorrected repr. TI")
    if truth is not None and len(truth):
        t = truth[truth["hws_bin_ms"].isin(b["hws_bin_ms"])].sort_values("hws_bin_ms")
        ax.plot(t["hws_bin_ms"], t["ti_mean"], "x", color="tab:red", ms=5, label="true bin mean")
        ax.plot(t["hws_bin_ms"], t["ti_rep"], "+", color="tab:red", ms=6, label="true repr. TI")
    vv = np.linspace(
        max(2.0, v.min() - 0.5) if v.size else 3.0, (v.max() + 0.5) if v.size else 20.0
    )
    for (cat, i_ref), ls in zip(
        IEC_TURBULENCE_CATEGORIES.items(), ("-", "--", "-.", ":"), strict=True
    ):
        ax.plot(vv, iec_representative_ti(vv, i_ref), ls, color="tab:green", lw=0.9, alpha=0.8)
        ax.annotate(f"IEC {cat}", (vv[-1], iec_representative_ti(vv[-1], i_ref)), fontsize=7,
                    color="tab:green", xytext=(2, 0), textcoords="offset points", va="center")  # fmt: skip
    ax.set_xlim(vv[0], vv[-1] + 1.3)
    top = np.nanmax(np.r_[b["ti_rep_hi"].to_numpy(dtype=float), 0.1]) if len(b) else 0.3
    ax.set_ylim(0, max(0.12, min(1.2 * top, 0.6)))
    ax.set_xlabel("HWS bin [m/s]")
    ax.set_ylabel("TI [-]")
    ax.set_title(title + " (green: IEC 61400-1 ed. 4 categories, representative TI)", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    return fig


def budget_figure(budget: pd.DataFrame, sources) -> Figure:
    """Variance share of each uncertainty source against the speed bin, one panel per height.

    Parameters
    ----------
    budget : pandas.DataFrame
        ``grouping == "speed bin"`` rows of results/ti/uncertainty_budget.csv:
        ``height_m``, ``hws_bin_ms`` and ``share_<source>``.
    sources : sequence of str
        The source names (columns ``share_<source>``).

    Returns
    -------
    matplotlib.figure.Figure
    """
    heights = sorted(budget["height_m"].unique()) or [np.nan]
    fig, axes = plt.subplots(1, len(heights), figsize=(3.6 * len(heights) + 1, 3.4),
                             sharey=True, squeeze=False)  # fmt: skip
    for ax, h in zip(axes[0], heights, strict=True):
        b = budget[budget["height_m"] == h].sort_values("hws_bin_ms")
        for k in sources:
            ax.plot(b["hws_bin_ms"], 100 * b[f"share_{k}"], "o-", ms=3, label=k)
        ax.set_title(f"{h:g} m", fontsize=10)
        ax.set_xlabel("HWS bin [m/s]")
        ax.axhline(0, color="k", lw=0.8)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("share of the variance of the bin mean [%]")
    axes[0][-1].legend(fontsize=7)
    fig.tight_layout()
    return fig


def posterior_figure(draws: dict[str, np.ndarray], *, title: str = "global posterior") -> Figure:
    """Marginal posterior histograms, one panel per parameter.

    Parameters
    ----------
    draws : dict of str -> numpy.ndarray, shape (nensembles, ndraws) or (ndraws,)
        Posterior draws per parameter; ensembles are overlaid in different colours.

    Returns
    -------
    matplotlib.figure.Figure
    """
    n = max(len(draws), 1)
    fig, axes = plt.subplots(1, n, figsize=(4 * n, 3.2), squeeze=False)
    for ax, (name, d) in zip(axes[0], draws.items(), strict=False):
        d = np.atleast_2d(np.asarray(d, float))
        for k, chain in enumerate(d):
            ax.hist(
                chain[np.isfinite(chain)],
                bins=40,
                histtype="step",
                density=True,
                label=f"ensemble {k}",
            )
        ax.set_xlabel(name)
        ax.set_yticks([])
    axes[0][0].legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def convergence_figure(bin_fits: pd.DataFrame, *, rhat_max: float, ess_min: float) -> Figure:
    """Per-bin convergence diagnostics: worst rank R-hat and minimum ESS against thresholds.

    Parameters
    ----------
    bin_fits : pandas.DataFrame
        results/inference/bin_fits.csv with ``bin_id, status`` and, when the fit ran,
        ``rhat_max`` and ``ess_bulk_min`` / ``ess_tail_min``.
    rhat_max, ess_min : float
        The thresholds of the config (dashed lines).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.5))
    ids = bin_fits["bin_id"].to_numpy()
    colour = np.where(bin_fits["status"].to_numpy() == "ok", "tab:green", "tab:red")
    for ax, col, thr, label in (
        (axes[0], "rhat", rhat_max, "rank R-hat (max over parameters)"),
        (axes[1], "ess", ess_min, "ESS (min of bulk and tail)"),
    ):
        cols = [c for c in bin_fits.columns if c.startswith(col)]
        if cols:
            vals = bin_fits[cols].min(axis=1) if col == "ess" else bin_fits[cols].max(axis=1)
            ax.scatter(ids, vals, c=colour, s=12)
        ax.axhline(thr, color="k", ls="--", lw=1)
        ax.set_xlabel("bin id (case no.)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    fig.suptitle("per-bin convergence (green: ok, red: failed or error)")
    fig.tight_layout()
    return fig


def calibration_figure(
    hws_ms: np.ndarray,
    ti_est: np.ndarray,
    ti_lo: np.ndarray,
    ti_hi: np.ndarray,
    references: dict[str, np.ndarray],
    *,
    credible_mass: float,
    speed_bin_width_ms: float = 2.0,
) -> Figure:
    """Coverage of the credible intervals and mean relative TI error against HWS.

    Parameters
    ----------
    hws_ms : numpy.ndarray, shape (n,)
        Mean HWS of the records (m/s).
    ti_est, ti_lo, ti_hi : numpy.ndarray, shape (n,)
        Corrected TI: median and interval bounds (-).
    references : dict of str -> tuple or numpy.ndarray
        Name -> reference TI (-), or name -> (reference TI, scale): the estimate and its
        interval are multiplied by ``scale`` (-) before the comparison (e.g. the motionless
        lidar's std ratio when comparing a point TI with a reference lidar).
    credible_mass : float
        Nominal coverage (-), drawn as a line with its binomial 95 % band per bin.
    speed_bin_width_ms : float
        Width of the HWS bins (m/s), centred on multiples of it
        (:func:`flidar_uq.data.binning.speed_bin_ms`).

    Returns
    -------
    matplotlib.figure.Figure
        Left: coverage per HWS bin with binomial 95 % error bars; right: mean relative
        error of the corrected TI per bin.
    """
    hws = np.asarray(hws_ms, float)
    centre = speed_bin_ms(hws, speed_bin_width_ms)
    fig, (ax_c, ax_e) = plt.subplots(1, 2, figsize=(10, 4))
    for k, (name, ref) in enumerate(references.items()):
        ref, scale = ref if isinstance(ref, tuple) else (ref, 1.0)
        ref = np.asarray(ref, float)
        scale = np.broadcast_to(np.asarray(scale, float), hws.shape)
        ok = np.isfinite(ti_est) & np.isfinite(ref) & np.isfinite(centre)
        xs, cov, half, err = [], [], [], []
        for c in np.unique(centre[ok]):
            m = ok & (centre == c)
            if m.sum() < 10:
                continue
            inside = (ref[m] >= ti_lo[m] * scale[m]) & (ref[m] <= ti_hi[m] * scale[m])
            p = inside.mean()
            xs.append(c)
            cov.append(p)
            half.append(1.96 * np.sqrt(max(p * (1 - p), 1e-12) / m.sum()))
            err.append(np.mean(ti_est[m] * scale[m] / ref[m] - 1.0))
        off = (k - 0.5) * 0.15 * speed_bin_width_ms
        ax_c.errorbar(np.add(xs, off), cov, yerr=half, fmt="o", ms=4, capsize=2, label=name)
        ax_e.plot(np.add(xs, off), 100 * np.asarray(err), "o-", ms=4, label=name)
    ax_c.axhline(credible_mass, color="k", ls="--", lw=1, label=f"nominal {credible_mass:.0%}")
    ax_c.set_xlabel("HWS (m/s)")
    ax_c.set_ylabel("coverage of the credible interval (-)")
    ax_c.set_ylim(max(0.0, min(credible_mass - 0.3, ax_c.get_ylim()[0])), 1.0)
    ax_c.legend(fontsize=8)
    ax_c.grid(alpha=0.3)
    ax_e.axhline(0.0, color="k", lw=1)
    ax_e.set_xlabel("HWS (m/s)")
    ax_e.set_ylabel("mean relative error of the corrected TI (%)")
    ax_e.legend(fontsize=8)
    ax_e.grid(alpha=0.3)
    fig.suptitle("calibration of the corrected TI by wind speed")
    fig.tight_layout()
    return fig

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
    "calibration_figure",
    "convergence_figure",
    "posterior_figure",
    "sigma_scatter_figure",
    "ti_vs_hws_figure",
]


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


def ti_vs_hws_figure(
    records: pd.DataFrame, *, credible_mass: float, bin_width_ms: float = 1.0
) -> Figure:
    """TI against HWS with credible bands (seed 000 Fig. 8b style).

    Parameters
    ----------
    records : pandas.DataFrame
        results/ti/records.csv: ``hws_mean_ms, ti_uncorrected, ti_corrected_median,
        ti_corrected_lo, ti_corrected_hi`` and optionally ``ti_true`` / ``ti_ref``.
    credible_mass : float
        Mass of the interval in the lo/hi columns (-), for the legend.
    bin_width_ms : float
        Width of the HWS bins of the average traces (m/s), centred on multiples of it
        (:func:`flidar_uq.data.binning.speed_bin_ms`).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = plt.subplots(figsize=(8, 4.5))
    r = records[np.isfinite(records["ti_corrected_median"])]
    hws = r["hws_mean_ms"].to_numpy()
    ax.plot(hws, r["ti_uncorrected"], ".", color="k", ms=2, alpha=0.4, label=r"$TI_{moving}$")
    ax.plot(
        hws,
        r["ti_corrected_median"],
        ".",
        color="0.55",
        ms=2,
        alpha=0.4,
        label="TI corrected (median)",
    )
    truth = "ti_true" if "ti_true" in r else ("ti_ref" if "ti_ref" in r else None)
    if truth is not None:
        ax.plot(hws, r[truth], ".", color="tab:red", ms=2, alpha=0.4, label=truth)
    if len(r):
        grp = r.assign(_bin=speed_bin_ms(hws, bin_width_ms)).groupby("_bin")
        means = grp[
            ["ti_uncorrected", "ti_corrected_median", "ti_corrected_lo", "ti_corrected_hi"]
        ].mean()
        c = means.index.to_numpy()
        ax.fill_between(
            c,
            means["ti_corrected_lo"],
            means["ti_corrected_hi"],
            color="tab:blue",
            alpha=0.25,
            label=f"{credible_mass:.0%} credible band (bin mean)",
        )
        ax.plot(c, means["ti_uncorrected"], "-", color="k", lw=2, label="moving, bin mean")
        ax.plot(
            c,
            means["ti_corrected_median"],
            "-",
            color="tab:blue",
            lw=2,
            label="corrected, bin mean",
        )
        if truth is not None:
            ax.plot(c, grp[truth].mean(), "-", color="tab:red", lw=2, label=f"{truth}, bin mean")
    ax.set_xlabel("HWS [m/s]")
    ax.set_ylabel("TI [-]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
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

"""Figures of the report (matplotlib, Agg backend); each function returns a Figure.

Inputs are plain arrays / DataFrames (the pipeline's result tables); nothing is read from
disk here. Styles follow the Gutiérrez-Antuñano et al. (2018) figures they reproduce (cited per
function) or the floating-lidar validation plots of the field (TI against the reference
with a regression line, bias per speed bin).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from flidar_uq.data.binning import speed_bin_ms  # noqa: E402
from flidar_uq.validation.reference import (  # noqa: E402
    IEC_TURBULENCE_CATEGORIES,
    iec_representative_ti,
)

__all__ = [
    "IEC_TURBULENCE_CATEGORIES",
    "budget_figure",
    "calibration_figure",
    "convergence_figure",
    "iec_representative_ti",
    "posterior_figure",
    "sigma_scatter_figure",
    "bias_bars_figure",
    "motion_context_figure",
    "ti_rose_figure",
    "ti_scatter_figure",
    "ti_speed_bins_figure",
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
    """sigma_moving against sigma_ref and the corrected stds (Gutiérrez-Antuñano et al. 2018, Figs. 4-5 style).

    Parameters
    ----------
    sigma_moving_ms : numpy.ndarray, shape (n,)
        Floating-lidar 10-min HWS std (m/s), x axis.
    sigma_ref_ms : numpy.ndarray, shape (n,)
        Reference (or true) HWS std (m/s): left panel, blue crosses.
    sigma_corr : dict of str -> numpy.ndarray, shape (n,)
        Motion-corrected reference std per law (Gutiérrez-Antuñano et al. 2018, Eqs. 15-17), m/s: right panel.
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


def _ti_limits(b: pd.DataFrame, *others: pd.DataFrame | None) -> tuple[float, float]:
    """y-limits (-) fitting the plotted bin statistics with a 10 % margin of their range
    (at least 0.005): a correction of a few thousandths stays visible. ``b``: speed-bin
    rows; ``others``: truth or reference rows (``ti_mean``, ``ti_rep``), or None."""
    cols = ["ti_mean", "ti_mean_lo", "ti_mean_hi", "ti_rep", "ti_rep_lo", "ti_rep_hi",
            "ti_mean_uncorrected", "ti_rep_uncorrected"]  # fmt: skip
    vals = [b[c].to_numpy(dtype=float) for c in cols if c in b]
    vals += [o[c].to_numpy(dtype=float) for o in others if o is not None for c in
             ("ti_mean", "ti_rep") if c in o]  # fmt: skip
    v = np.concatenate(vals) if vals else np.empty(0)
    v = v[np.isfinite(v)]
    if not v.size:
        return 0.0, 0.3
    margin = max(0.1 * (v.max() - v.min()), 0.005)
    return max(0.0, v.min() - margin), v.max() + margin


def ti_speed_bins_figure(
    speed_bins: pd.DataFrame,
    records: pd.DataFrame | None = None,
    *,
    credible_mass: float,
    title: str = "",
    truth: pd.DataFrame | None = None,
    reference: pd.DataFrame | None = None,
    corrected: bool = True,
) -> Figure:
    """Corrected TI per speed bin with the IEC 61400-1 categories (Gutiérrez-Antuñano et al.
    2018, Fig. 8b style): corrected, uncorrected and reference, mean and representative.

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
    reference : pandas.DataFrame, optional
        ``hws_bin_ms``, ``ti_mean``, ``ti_rep`` of the reference instrument's TI per bin.
    corrected : bool
        False for a campaign without motion statistics: the uncorrected TI only (bins
        with an uncorrected statistic; ``records`` drawn with ``ti_uncorrected``).

    Returns
    -------
    matplotlib.figure.Figure
        The bands are the credible intervals of the bin mean and of the bin's
        representative TI (from the draws of the bin statistic), as the legend says.
    """
    fig, ax = plt.subplots(figsize=(10.5, 4.5))
    stat = "ti_mean" if corrected else "ti_mean_uncorrected"
    b = speed_bins[np.isfinite(speed_bins[stat])].sort_values("hws_bin_ms")
    if records is not None and len(records):
        ax.plot(
            records["hws_mean_ms"],
            records["ti_corrected_median" if corrected else "ti_uncorrected"],
            ".",
            color="0.75",
            ms=1.5,
            alpha=0.4,
            label="records, corrected (median)" if corrected else "records, uncorrected",
            zorder=1,
        )
    v = b["hws_bin_ms"].to_numpy(dtype=float)
    pct = f"{credible_mass:.0%}"
    if corrected:
        ax.fill_between(v, b["ti_mean_lo"], b["ti_mean_hi"], color="tab:blue", alpha=0.35,
                        zorder=2)  # fmt: skip
        ax.plot(v, b["ti_mean"], "o-", color="tab:blue", ms=3, lw=1.5, zorder=3,
                label=f"corrected bin mean, {pct} interval of the mean")  # fmt: skip
        ax.fill_between(v, b["ti_rep_lo"], b["ti_rep_hi"], color="tab:orange", alpha=0.35,
                        zorder=2)  # fmt: skip
        ax.plot(v, b["ti_rep"], "s-", color="tab:orange", ms=3, lw=1.5, zorder=3,
                label=f"corrected representative TI, {pct} interval")  # fmt: skip
    ax.plot(v, b["ti_mean_uncorrected"], "--", color="k", lw=1, label="uncorrected bin mean")
    ax.plot(v, b["ti_rep_uncorrected"], ":", color="k", lw=1.2, label="uncorrected repr. TI")
    if truth is not None and len(truth):
        t = truth[truth["hws_bin_ms"].isin(b["hws_bin_ms"])].sort_values("hws_bin_ms")
        ax.plot(t["hws_bin_ms"], t["ti_mean"], "x", color="tab:red", ms=5, label="true bin mean")
        ax.plot(t["hws_bin_ms"], t["ti_rep"], "+", color="tab:red", ms=6, label="true repr. TI")
    if reference is not None and len(reference):
        r = reference.sort_values("hws_bin_ms")
        ax.plot(r["hws_bin_ms"], r["ti_mean"], "D", color="tab:purple", ms=4, mfc="none",
                label="reference bin mean")  # fmt: skip
        ax.plot(r["hws_bin_ms"], r["ti_rep"], "v", color="tab:purple", ms=5, mfc="none",
                label="reference repr. TI")  # fmt: skip
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
    ax.set_ylim(*_ti_limits(b, truth, reference))
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


def _regression_panel(ax, reference, estimate, stats, *, label: str, colour: str) -> None:
    ok = np.isfinite(reference) & np.isfinite(estimate)
    ax.plot(reference[ok], estimate[ok], ".", color=colour, ms=2, alpha=0.35)
    top = float(np.nanmax(np.r_[reference[ok], estimate[ok], 0.05])) * 1.05
    ax.plot([0, top], [0, top], "k--", lw=1, label="1:1")
    if np.isfinite(stats.slope):
        xx = np.array([0.0, top])
        ax.plot(xx, stats.slope * xx + stats.offset, "-", color="k", lw=1.5,
                label=f"y = {stats.slope:.3f} x {stats.offset:+.4f}")  # fmt: skip
    ax.text(0.98, 0.03, f"n = {stats.n}\nbias = {stats.bias:+.4f} ({100 * stats.bias_rel:+.1f} %)"
            f"\nRMSE = {stats.rmse:.4f}\nR² = {stats.r2:.3f}", transform=ax.transAxes,
            ha="right", va="bottom", fontsize=8,
            bbox={"facecolor": "white", "alpha": 0.8, "lw": 0})  # fmt: skip
    ax.set_xlim(0, top)
    ax.set_ylim(0, top)
    ax.set_aspect("equal")
    ax.set_xlabel("reference TI [-]")
    ax.set_ylabel(f"{label} TI [-]")
    ax.set_title(label, fontsize=10)
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(alpha=0.3)


def ti_scatter_figure(reference, corrected, uncorrected, *, title: str = "") -> Figure:
    """Corrected and uncorrected TI against the reference TI, each with its regression line.

    Parameters
    ----------
    reference, corrected, uncorrected : array_like, shape (n,)
        TI per record (-): the reference's, the corrected TI in the reference's terms and
        the floating lidar's uncorrected TI.
    title : str

    Returns
    -------
    matplotlib.figure.Figure
        Two panels; each line is the least-squares fit ``TI = slope * TI_ref + offset``
        (:func:`flidar_uq.validation.reference.agreement`), its statistics in the corner.
    """
    from flidar_uq.validation.reference import agreement

    ref = np.asarray(reference, float)
    fig, axes = plt.subplots(1, 2, figsize=(9, 4.4))
    for ax, est, label, colour in (
        (axes[0], np.asarray(corrected, float), "corrected", "tab:blue"),
        (axes[1], np.asarray(uncorrected, float), "uncorrected", "0.3"),
    ):
        _regression_panel(ax, ref, est, agreement(est, ref), label=label, colour=colour)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def bias_bars_figure(
    corrected: pd.DataFrame, uncorrected: pd.DataFrame, *, title: str = ""
) -> Figure:
    """Mean TI bias against the reference per speed bin: corrected and uncorrected bars.

    Parameters
    ----------
    corrected, uncorrected : pandas.DataFrame
        :func:`flidar_uq.validation.reference.agreement_by_speed_bin` tables (``hws_bin_ms``,
        ``bias``, -; ``ti_rep_error``, -).
    title : str

    Returns
    -------
    matplotlib.figure.Figure
        Left: mean bias; right: representative-TI error, per bin (m/s).
    """
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6), sharex=True)
    w = 0.38
    for ax, col, label in ((axes[0], "bias", "mean TI bias [-]"),
                           (axes[1], "ti_rep_error", "representative-TI error [-]")):  # fmt: skip
        for k, (tab, name, colour) in enumerate(
            ((corrected, "corrected", "tab:blue"), (uncorrected, "uncorrected", "0.55"))
        ):
            ax.bar(tab["hws_bin_ms"] + (k - 0.5) * w, tab[col], width=w, color=colour, label=name)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xlabel("HWS bin [m/s]")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3, axis="y")
    axes[0].legend(fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def ti_rose_figure(sectors: pd.DataFrame) -> Figure:
    """Mean corrected TI per wind-direction sector, one line per height (a TI rose).

    Parameters
    ----------
    sectors : pandas.DataFrame
        ``grouping == "direction sector"`` rows of results/ti/groups.csv: ``height_m``,
        ``group`` (sector centre, deg from north, clockwise), ``ti_mean`` (-), ``n``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = plt.figure(figsize=(5, 4.6))
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    for h, sub in sectors.groupby("height_m", sort=True):
        sub = sub.assign(deg=sub["group"].astype(float)).sort_values("deg")
        sub = sub[np.isfinite(sub["ti_mean"].to_numpy(dtype=float))]
        if not len(sub):
            continue
        th = np.deg2rad(np.r_[sub["deg"], sub["deg"].iloc[0]])
        ax.plot(th, np.r_[sub["ti_mean"], sub["ti_mean"].iloc[0]], "o-", ms=3, label=f"{h:g} m")
    ax.set_title("mean corrected TI per direction sector [-]", fontsize=10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.05, 1.0))
    fig.tight_layout()
    return fig


def motion_context_figure(
    tilt_deg, period_s, sea_state_error: pd.DataFrame | None = None
) -> Figure:
    """The buoy's motion: tilt amplitude and period distributions, error by sea state.

    Parameters
    ----------
    tilt_deg, period_s : array_like, shape (n,)
        Per record: the larger of the roll and pitch amplitudes (deg) and the motion
        period (s).
    sea_state_error : pandas.DataFrame, optional
        ``sea_state``, ``corrected`` and ``uncorrected`` (mean TI bias against the
        reference per sea-state class, -): a third panel.

    Returns
    -------
    matplotlib.figure.Figure
    """
    n = 3 if sea_state_error is not None and len(sea_state_error) else 2
    fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 3.4))
    for ax, x, label in ((axes[0], tilt_deg, "tilt amplitude (max of roll, pitch) [deg]"),
                         (axes[1], period_s, "motion period [s]")):  # fmt: skip
        x = np.asarray(x, float)
        ax.hist(x[np.isfinite(x)], bins=40, color="tab:cyan")
        ax.set_xlabel(label)
        ax.set_ylabel("records")
        ax.grid(alpha=0.3)
    if n == 3:
        e = sea_state_error
        y = np.arange(len(e))
        axes[2].barh(y - 0.2, e["corrected"], height=0.4, color="tab:blue", label="corrected")
        axes[2].barh(y + 0.2, e["uncorrected"], height=0.4, color="0.55", label="uncorrected")
        axes[2].set_yticks(y, e["sea_state"], fontsize=7)
        axes[2].axvline(0, color="k", lw=0.8)
        axes[2].set_xlabel("mean TI bias against the reference [-]")
        axes[2].legend(fontsize=7)
        axes[2].grid(alpha=0.3, axis="x")
    fig.tight_layout()
    return fig

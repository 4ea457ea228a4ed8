"""Stage 2: posterior of the global correlation rho (and tau0, kappa, lever arm, motion scale)
from the records with a reference, and the choice among the nested global models.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.special import logsumexp

from flidar_uq.inference.densities import _global_loglik_pointwise, log_prob_global
from flidar_uq.inference.diagnostics import _diagnostics, _thin
from flidar_uq.inference.loo import _loo, _loo_compare
from flidar_uq.inference.observations import effective_sigma_z_ms, record_sigma_z_moments
from flidar_uq.inference.priors import Priors, SamplerSettings
from flidar_uq.inference.results import GlobalFit
from flidar_uq.inference.sampler import _run_ensembles, laplace_init
from flidar_uq.seeding import as_seedsequence
from flidar_uq.threads import single_threaded

_GLOBAL_NAMES = ["rho", "tau0_ms", "kappa"]


def _per_bin_rho_loo(s, r, szm, szv, bins, tau0, kappa, rng, ndraws, priors):
    """Per-bin rho with tau0, kappa fixed at their global medians; exact 1-D grid posterior."""
    grid = np.linspace(-0.9995, 0.9995, 400)
    half = 0.5 * (grid[1] - grid[0])
    ll_all = np.zeros((ndraws, s.size))
    theta = np.column_stack(
        [grid, np.full(grid.size, np.log(tau0)), np.full(grid.size, np.log(kappa))]
    )
    for b in np.unique(bins):
        m = bins == b
        lp = _global_loglik_pointwise(theta, s[m], r[m], szm[m], szv[m]).sum(axis=1)
        p = np.exp(lp - logsumexp(lp))
        idx = rng.choice(grid.size, size=ndraws, p=p)
        rho = grid[idx] + rng.uniform(-half, half, size=ndraws)  # continuous within the cell
        th = np.column_stack([rho, np.full(ndraws, np.log(tau0)), np.full(ndraws, np.log(kappa))])
        ll_all[:, m] = _global_loglik_pointwise(th, s[m], r[m], szm[m], szv[m])
    return ll_all[None, :, :]


def _global_init_fn(s, r, szm, szv, u2, priors, ndim, corr=None):
    """Overdispersed start of the global fit (:func:`laplace_init` on its log posterior)."""

    def broad(rng, n):
        cols = [
            rng.uniform(-0.9, 0.9, n),
            np.log(rng.uniform(0.01, 0.2, n)),
            np.log(rng.uniform(0.02, 0.3, n)),
            rng.uniform(0.0, 5.0, n),
            rng.uniform(-0.3, 0.3, n),
        ]
        return np.column_stack(cols[:ndim])

    x0 = np.array([0.0, np.log(0.05), np.log(0.1), 2.0, 0.0][:ndim])
    return laplace_init(log_prob_global, (s, r, szm, szv, priors, u2, corr), x0, broad)


def _sample_global(s, r, szm, szv, u2, settings, seedseq, priors, ndim, corr=None):
    """emcee run of the global model: 3 parameters, 4 with the lever arm (``u2``; a DBS
    lidar's cross term ``corr``), 5 with the motion-model scale too."""
    init = _global_init_fn(s, r, szm, szv, u2, priors, ndim, corr)
    names = (_GLOBAL_NAMES + ["lever_arm_m", "motion_scale"])[:ndim]
    logs = [k for k in (1, 2, 4) if k < ndim]  # sampled as logs, reported natural

    def check(ch):
        nat = ch.copy()
        nat[..., logs] = np.exp(ch[..., logs])
        return _diagnostics(nat, names, settings)

    chains, diag, reasons = _run_ensembles(
        log_prob_global, (s, r, szm, szv, priors, u2, corr), init, ndim, settings, seedseq, check
    )
    thin = _thin(chains, settings.ndraws)
    ll = _global_loglik_pointwise(thin.reshape(-1, ndim), s, r, szm, szv, u2, corr)
    ll = ll.reshape(thin.shape[0], thin.shape[1], -1)
    draws = {n: (np.exp(thin[..., k]) if k in logs else thin[..., k]) for k, n in enumerate(names)}
    return draws, ll, diag, reasons


# fixed order: each model's seed is its child index; the number of parameters of each
_GLOBAL_MODELS = ("rho_only", "lever_arm", "lever_arm_scale")


_GLOBAL_NDIM = {"rho_only": 3, "lever_arm": 4, "lever_arm_scale": 5}


@single_threaded
def fit_global(
    records: pd.DataFrame,
    bin_fits,
    *,
    surrogate=None,
    settings: SamplerSettings = SamplerSettings(),
    seed,
    priors: Priors = Priors(),
    use_unconverged_bins: bool = False,
    lever_arm="auto",
    scan_period_s: float = 1.0,
) -> GlobalFit:
    """Posterior of ``rho``, ``tau0_ms``, ``kappa`` [, ``lever_arm_m``] from the records with a reference (stage 2).

    Only records of converged bins with finite ``hws_std_ms``, ``ref_hws_std_ms`` and a
    positive sigma_Z are used; the bins left out are listed in ``info["excluded_bins"]``.
    With no usable record the posterior is the prior and the fit is marked failed.

    Parameters
    ----------
    records : pandas.DataFrame
        All records with ``bin_id``, ``hws_mean_ms``, ``hws_std_ms``, ``ref_hws_std_ms``.
    bin_fits : sequence of BinFit
    surrogate : SigmaZSurrogate, optional
    settings : SamplerSettings
    seed : int or numpy.random.SeedSequence
    priors : Priors
    use_unconverged_bins : bool
        Only for simulation-based calibration (which must not condition on convergence):
        also use the records of bins that failed the convergence criteria.
    lever_arm : "auto", bool or str
        ``"auto"``: fit the three nested models -- rho only; plus an effective lever arm
        ``lever_arm_m`` (head translation, :func:`translation_unit_sq`); plus a
        motion-model scale ``motion_scale`` of the surrogate's rotational sigma_Z (the
        harmonic-motion surrogate against a broadband real sea) -- and keep the one
        :func:`select_global_model` picks (a richer model only if it converged and
        PSIS-LOO prefers it by more than ``loo_threshold_se`` se). False / True /
        ``"lever_arm_scale"`` (or a model name): fit only that model. Each model's result
        depends only on ``seed``, not on whether the others are fitted: the models run
        as separate jobs and :func:`select_global_model` give the same result as
        ``"auto"``.
    scan_period_s : float
        VAD scan duration (s) for the translation term (1 s for the ZephIR 300). A pulsed
        DBS lidar (``surrogate.lidar``) has its own terms instead: its beam-pair phasors
        with the cross term between the tilt leak and the head translation, at each
        record's wind direction relative to the beams (:func:`record_sigma_z_moments`).

    Returns
    -------
    GlobalFit
        ``info["loo"]`` holds ``model`` (a name of ``_GLOBAL_MODELS``) and the comparison of the
        global with a per-bin rho (see docs/inference.md); with ``"auto"`` also the
        lever-arm comparison.
    """
    for c in ("bin_id", "hws_mean_ms", "hws_std_ms"):
        if c not in records:
            raise ValueError(f"fit_global: records lack column {c!r}")
    if isinstance(lever_arm, str):
        if lever_arm != "auto" and lever_arm not in _GLOBAL_MODELS:
            raise ValueError(
                f"fit_global: lever_arm={lever_arm!r} is not 'auto', True, False or one of "
                f"{_GLOBAL_MODELS}"
            )
        models = _GLOBAL_MODELS if lever_arm == "auto" else (lever_arm,)
    elif lever_arm in (True, False):
        models = ("lever_arm" if lever_arm else "rho_only",)
    else:
        raise ValueError(f"fit_global: lever_arm={lever_arm!r} is not 'auto', True or False")
    seedseq = as_seedsequence(seed)
    ss_sz, ss_mc, ss_loo = seedseq.spawn(3)
    n_models = len(_GLOBAL_MODELS)
    mc_children, loo_children = ss_mc.spawn(n_models), ss_loo.spawn(n_models)
    bin_fits = list(bin_fits)
    good = [f for f in bin_fits if f.converged or use_unconverged_bins]
    excluded = [f.bin_id for f in bin_fits if not (f.converged or use_unconverged_bins)]
    szm, szv, u2m, corr = record_sigma_z_moments(
        records,
        good,
        surrogate=surrogate,
        ndraws=settings.n_sz_draws,
        seed=ss_sz,
        scan_period_s=scan_period_s,
    )
    s = records["hws_std_ms"].to_numpy(dtype=float)
    r = (
        records["ref_hws_std_ms"].to_numpy(dtype=float)
        if "ref_hws_std_ms" in records
        else np.full(len(records), np.nan)
    )
    use = np.isfinite(s) & np.isfinite(r) & (s > 0) & (r > 0) & np.isfinite(szm) & (szm > 0)
    use &= np.isfinite(u2m)
    if corr is not None:
        use &= np.isfinite(corr)
    data = {
        "s": s[use],
        "r": r[use],
        "szm": szm[use],
        "szv": szv[use],
        "u2": u2m[use],
        "corr": None if corr is None else corr[use],
        "bins": records["bin_id"].to_numpy()[use],
    }
    gs = settings.for_global_fit()
    fits, loos = {}, {}
    for name in models:
        k = _GLOBAL_MODELS.index(name)
        fits[name], loos[name] = _fit_global_model(
            name, data, gs, mc_children[k], loo_children[k], priors, settings.loo_threshold_se
        )
        fits[name].info.update(
            {
                "excluded_bins": excluded,
                "constant": {"record_index": np.asarray(records.index)[use]},
            }
        )
    if len(fits) == 1:
        return fits[models[0]]
    return _select_global(fits, loos, settings)


def _fit_global_model(name, data, settings, ss_mc, ss_loo, priors, loo_threshold_se):
    """One global model on prepared data; returns (GlobalFit, its PSIS-LOO dict or None)."""
    s, r, szm, szv, bins = data["s"], data["r"], data["szm"], data["szv"], data["bins"]
    u2 = None if name == "rho_only" else data["u2"]
    corr = None if name == "rho_only" else data.get("corr")  # None: a CW lidar
    prior_only = s.size == 0
    draws, ll, diag, reasons = _sample_global(
        s, r, szm, szv, u2, settings, ss_mc, priors, _GLOBAL_NDIM[name], corr
    )
    reasons = list(reasons)  # prior only: the prior's answer (info["prior_only"]), not a failure
    loo_info = {"model": name}
    lg = None if prior_only else _loo(ll)
    if name != "rho_only":  # per-bin rho comparison at the median lever arm (and scale)
        lev = float(np.median(draws["lever_arm_m"]))
        k = float(np.median(draws["motion_scale"])) if "motion_scale" in draws else 1.0
        sz_eff = effective_sigma_z_ms(szm, u2, lev, k, corr)
        rot = k * szm if corr is None else k * szm + corr * lev * np.sqrt(u2)
        szv = k**2 * szv * (rot / np.maximum(sz_eff, 1e-12)) ** 2
        szm = sz_eff
    if not prior_only and np.unique(bins).size > 1:
        llb = _per_bin_rho_loo(
            s,
            r,
            szm,
            szv,
            bins,
            np.median(draws["tau0_ms"]),
            np.median(draws["kappa"]),
            np.random.default_rng(ss_loo),
            1000,
            priors,
        )
        lb = _loo(llb)
        if lg is None or lb is None:
            loo_info.update({"loo_failed": True, "preferred": "global"})
        else:
            d, se = _loo_compare(lb, lg)
            loo_info.update(
                {
                    "global_elpd": lg["elpd"],
                    "per_bin_elpd": lb["elpd"],
                    "elpd_diff": d,
                    "elpd_diff_se": se,
                    "global_pareto_k_max": float(np.max(lg["pareto_k"])),
                    "per_bin_pareto_k_max": float(np.max(lb["pareto_k"])),
                    "preferred": "per_bin" if d > loo_threshold_se * se else "global",
                }
            )
    rho = draws["rho"].ravel()
    info = {
        "n_records": int(s.size),
        "prior_only": prior_only,
        "excluded_bins": [],
        "loo": loo_info,
        "rho_mass_beyond_0p98": float(np.mean(np.abs(rho) > 0.98)),
    }
    fit = GlobalFit(
        draws=draws, log_lik=ll, diagnostics=diag, failure_reasons=reasons, info=info,
        pointwise_loo=lg,
    )  # fmt: skip
    return fit, lg


@single_threaded
def select_global_model(
    fit_rho_only: GlobalFit,
    fit_lever_arm: GlobalFit,
    fit_lever_arm_scale: GlobalFit | None = None,
    *,
    settings: SamplerSettings = SamplerSettings(),
) -> GlobalFit:
    """Pick among the nested global models by PSIS-LOO (the choice of ``fit_global(lever_arm="auto")``).

    Starting from the rho-only model, each richer model (lever arm, then lever arm and
    motion-model scale) replaces the current choice if it converged and its elpd exceeds
    the current choice's by more than ``settings.loo_threshold_se`` standard errors of the
    difference. All fits must come from :func:`fit_global` on the same records (one
    model each, e.g. as parallel jobs; fits read back with :func:`load_fit` work: the
    pointwise log-likelihood is stored).

    Parameters
    ----------
    fit_rho_only, fit_lever_arm : GlobalFit
    fit_lever_arm_scale : GlobalFit, optional
        Without it the choice is between the first two.
    settings : SamplerSettings
        Only ``loo_threshold_se`` is used.

    Returns
    -------
    GlobalFit
        The chosen fit (a copy) with ``info["loo"]`` extended by ``<model>_elpd_diff``,
        ``<model>_elpd_diff_se`` (against the next simpler model) and ``<model>_pareto_k_max``.

    Raises
    ------
    ValueError
        If a fit is not the named model or the fits were not made on the same records.
    """
    fits = {"rho_only": fit_rho_only, "lever_arm": fit_lever_arm}
    if fit_lever_arm_scale is not None:
        fits["lever_arm_scale"] = fit_lever_arm_scale
    for name, f in fits.items():
        if not isinstance(f, GlobalFit) or f.info.get("loo", {}).get("model") != name:
            raise ValueError(f"select_global_model: fit_{name} is not a {name!r} GlobalFit")
    idx = [np.asarray(f.info.get("constant", {}).get("record_index", [])) for f in fits.values()]
    if any(i.shape != idx[0].shape or not np.array_equal(i, idx[0]) for i in idx[1:]):
        raise ValueError("select_global_model: the fits were not made on the same records")
    loos = {name: None if f.info["prior_only"] else f.loo() for name, f in fits.items()}
    return _select_global(fits, loos, settings)


def _select_global(fits, loos, settings):
    chosen = "rho_only"
    extra = {}
    names = [m for m in _GLOBAL_MODELS if m in fits]
    if all(loos.get(m) is not None for m in names):
        extra["rho_only_pareto_k_max"] = float(np.max(loos["rho_only"]["pareto_k"]))
        for simpler, richer in zip(names[:-1], names[1:], strict=True):
            d, se = _loo_compare(loos[richer], loos[simpler])
            extra.update(
                {
                    f"{richer}_elpd_diff": d,
                    f"{richer}_elpd_diff_se": se,
                    f"{richer}_pareto_k_max": float(np.max(loos[richer]["pareto_k"])),
                }
            )
            dc, sec = _loo_compare(loos[richer], loos[chosen])
            if fits[richer].converged and dc > settings.loo_threshold_se * sec:
                chosen = richer
    fit = fits[chosen]
    info = {**fit.info, "loo": {**fit.info["loo"], **extra}}
    return GlobalFit(
        draws=fit.draws,
        log_lik=fit.log_lik,
        diagnostics=fit.diagnostics,
        failure_reasons=list(fit.failure_reasons),
        info=info,
        pointwise_loo=fit.pointwise_loo,
    )

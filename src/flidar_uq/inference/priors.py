"""Priors and sampler settings of the inference, and draws from the motion prior.

Rule of inference/: depends on flidar_uq.physics, flidar_uq.data, seeding and threads only.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class Priors:
    """Weakly informative, physical priors (justified in docs/inference.md).

    Amplitude ``A`` (deg): log-normal, median ``amplitude_median_deg``, log-sd
    ``amplitude_log_sd``, truncated to [``amplitude_min_deg``, ``amplitude_max_deg``].
    Periods ``T`` (s): log-normal, median ``period_median_s``, log-sd ``period_log_sd``,
    truncated to [``period_min_s``, ``period_max_s``]; two-period: both periods with this
    prior and ordered ``T1 < T2``; weight ``w ~ Beta(weight_beta, weight_beta)`` (the
    expected share of a record's tilt variance in the short-period peak); concentration of
    the records' variance shares about ``w``, ``log c ~ Normal(log
    weight_concentration_median, weight_concentration_log_sd)`` on
    [``weight_concentration_min``, ``weight_concentration_max``].
    Within-bin log-scatter of the IMU statistics: half-normal(``scatter_scale``) on
    [``scatter_min``, ``scatter_max``]. ``rho ~ Uniform(-1, 1)``;
    ``tau0 ~ HalfNormal(tau0_scale_ms)``; ``kappa ~ HalfNormal(kappa_scale)``;
    effective lever arm ``L ~ HalfNormal(lever_arm_scale_m)`` on [0, ``lever_arm_max_m``);
    motion-model scale of the surrogate's rotational sigma_Z
    ``log k ~ Normal(0, motion_scale_log_sd)`` on ``|log k| < log 5``. Record motion model
    (:mod:`flidar_uq.inference.record_fit`): ``kappa_z ~ HalfNormal(kappa_z_scale)``,
    ``log k ~ Normal(0, record_motion_scale_log_sd)``, the scatter of a record's realised
    correlation (the sd of its Fisher z) ``log rho_sd ~ Normal(log rho_sd_median,
    rho_sd_log_sd)``, the hull response
    ``h ~ HalfNormal(hull_response_scale)`` on (0, ``hull_response_max``], sampled as
    ``log h`` (as ``kappa``: for a buoy that only rotates its posterior is the prior's
    ``exp(log h)`` tail, with no wall for the sampler).

    ``kappa`` and ``kappa_z`` are sampled as logs on [``kappa_min``, ...): the bound only
    keeps the log finite. With a fixed reference lidar the pair term explains the
    floating lidar's scatter and ``kappa`` goes to 0; its log posterior is then the
    prior's ``exp(log kappa)`` tail, proper without any bound. A bound of 1e-4 cut that
    tail where a year's records put its peak (log kappa ~ -8.6) and slowed the record
    fit's sampler fourfold (autocorrelation time 13-16 steps against 3-4 at 1e-8;
    docs/performance.md), so it sits far below anything measurable.
    """

    amplitude_median_deg: float = 3.0
    amplitude_log_sd: float = 0.8
    amplitude_min_deg: float = 0.05
    amplitude_max_deg: float = 25.0
    period_median_s: float = 5.0
    period_log_sd: float = 0.5
    period_min_s: float = 1.0
    period_max_s: float = 20.0
    weight_beta: float = 2.0
    weight_concentration_median: float = 10.0
    weight_concentration_log_sd: float = 1.0
    weight_concentration_min: float = 0.5
    weight_concentration_max: float = 2000.0
    scatter_scale: float = 0.3
    scatter_min: float = 0.03
    scatter_max: float = 2.0
    tau0_scale_ms: float = 0.1
    kappa_scale: float = 0.2
    tau0_min_ms: float = 1e-4
    kappa_min: float = 1e-8
    lever_arm_scale_m: float = 3.0
    lever_arm_max_m: float = 20.0
    motion_scale_log_sd: float = 0.3
    kappa_z_scale: float = 0.3
    record_motion_scale_log_sd: float = 0.1
    #: median of the log-normal prior of ``rho_sd`` (-): the sample correlation of two
    #: series of ``N`` independent pairs has ``sd(atanh r) = 1 / sqrt(N - 3)`` (Fisher
    #: 1921); a 10-min record holds ``N`` of 15 (the turbulence's integral time scale,
    #: about 40 s) to 600 (1-Hz values), so 0.04-0.26, centred on ``N`` = 100
    rho_sd_median: float = 0.1
    #: log-sd of that prior (-): 0.5 spans 0.04-0.27 (95 %)
    rho_sd_log_sd: float = 0.5
    #: upper end of the prior of the record model's hull response ``h`` (-): 0
    #: rotates about a fixed centre, 1 follows the waves; a hull near resonance responds
    #: more than the waves (docs/inference.md)
    hull_response_max: float = 1.5
    #: half-normal scale of the hull response (-): a wave follower (1) at one scale
    hull_response_scale: float = 1.0


@dataclass(frozen=True)
class SamplerSettings:
    """emcee and convergence settings.

    Parameters
    ----------
    nwalkers : int
        Walkers per ensemble (the two-period model uses at least 2 * ndim + 2 = 14).
    nsteps : int
        Steps kept per ensemble after burn-in.
    nburn : int
        Burn-in steps discarded per ensemble.
    nensembles : int
        Independent ensembles (>= 4); R-hat is computed across them.
    ndraws : int
        Draws stored per ensemble (thinned uniformly from the pooled walkers).
    snooker_weight : float
        Share of DESnookerMove (rest DEMove) during the first half of the burn-in (mild
        multimodality).
    independence_weight : float
        Share of the Student-t independence Metropolis move (fitted to the burn-in, per
        ensemble) in the second half of the burn-in and the main phase; the rest is
        DEMove. It cuts the autocorrelation time to ~2-4 steps for near-Gaussian
        posteriors. In the main phase it is scaled down in proportion to the move's
        expected acceptance rate when that is below 0.5 (a posterior at a boundary or
        banana-shaped is left mostly to DE; the adaptive extension lengthens such chains).
    mixture : str
        ``"auto"``: the two-period model when at least ``two_period_min_share`` of the
        bin's IMU records (and at least 3) have a two-peaked motion spectrum of their own
        (``period1_s``, ``period2_s``, ``weight1`` given), else the unimodal model;
        ``"never"``; ``"always"`` (two-period whenever 3 records are two-peaked).
    two_period_min_share : float
        See ``mixture``. The two-peak detection (:func:`flidar_uq.data.imu.two_peaks`)
        flags ~1 % of long-crested single-peaked records and ~99 % with a swell; on the
        default virtual campaign 36 % and 81 % (docs/inference.md): 0.5 asks for a majority.
    max_step_factor : float
        The main phase is extended adaptively (all ensembles equally), and every
        convergence criterion (R-hat, bulk/tail ESS, ``n_autocorr``) re-checked after each
        extension, until all pass with the chain longer than ``1.1 n_autocorr``
        autocorrelation times, at most to this many times ``nsteps`` (the stated cap; a
        criterion still missed there marks the fit failed).
    two_period_step_factor : float
        The two-period model (7 parameters, longer autocorrelation) runs this many times
        ``nsteps`` and ``nburn``.
    global_step_factor : float
        The global fit runs this many times ``nsteps`` and ``nburn`` (1: on a campaign its
        3-4 parameter posterior is near-Gaussian, autocorrelation time ~2-3 steps, and it
        starts from a widened Laplace approximation).
    global_max_step_factor : float
        ``max_step_factor`` of the global fit (relative to its ``nsteps``): with few
        records the ``tau0``/``kappa`` posterior is banana-shaped (autocorrelation time
        ~20-40 steps) and needs the longer extension, and so does the record model of a
        hull that translates (the lever arm, motion scale and hull response trade off along
        a curved valley: ~60-80 steps on a wave follower); a near-Gaussian one never uses
        it.
    rhat_max, ess_min, n_autocorr : float
        Convergence thresholds (docs/inference.md, "Convergence policy") (rank R-hat, bulk and tail ESS, chain length
        in integrated autocorrelation times).
    record_fit_max_records : int
        Most records the record model is fitted on (records): a longer campaign is fitted
        on a subsample stratified by height and 1-m/s wind-speed bin, evenly spaced in
        time within each stratum (:func:`~flidar_uq.inference.record_fit.fit_subsample`).
        Its seven parameters are campaign constants, so their posterior from 30,000 records
        is already narrow, while the sampler's cost grows with records times steps. Every
        record is still corrected with the posterior.
    """

    nwalkers: int = 16
    nsteps: int = 250
    nburn: int = 100
    nensembles: int = 4
    ndraws: int = 250
    snooker_weight: float = 0.2
    independence_weight: float = 0.85
    two_period_step_factor: float = 2.0
    max_step_factor: float = 6.0
    global_step_factor: float = 1.0
    global_max_step_factor: float = 48.0
    mixture: str = "auto"
    two_period_min_share: float = 0.5
    loo_threshold_se: float = 2.0
    rhat_max: float = 1.01
    ess_min: float = 400.0
    n_autocorr: float = 50.0
    n_sz_draws: int = 200
    record_fit_max_records: int = 30_000

    def for_global_fit(self) -> SamplerSettings:
        """These settings as a global fit runs them: ``global_step_factor`` times the steps
        and burn-in, ``global_max_step_factor`` as the extension cap."""
        f = self.global_step_factor
        return replace(
            self,
            nsteps=int(round(self.nsteps * f)),
            nburn=int(round(self.nburn * f)),
            max_step_factor=self.global_max_step_factor,
        )

    def __post_init__(self):
        if self.nensembles < 4:
            raise ValueError(
                f"SamplerSettings: nensembles={self.nensembles} < 4 (docs/inference.md)"
            )
        if self.mixture not in {"auto", "never", "always"}:
            raise ValueError(f"SamplerSettings: mixture={self.mixture!r} not auto/never/always")
        if not 0.0 < self.two_period_min_share <= 1.0:
            raise ValueError(
                f"SamplerSettings: two_period_min_share={self.two_period_min_share} not in (0, 1]"
            )
        if self.record_fit_max_records < 100:
            raise ValueError(
                f"SamplerSettings: record_fit_max_records={self.record_fit_max_records} < 100"
            )
        if self.nsteps < 10 or self.nburn < 0 or self.nwalkers < 8:
            raise ValueError(
                f"SamplerSettings: need nsteps >= 10, nburn >= 0, nwalkers >= 8; got "
                f"{self.nsteps}, {self.nburn}, {self.nwalkers}"
            )


def sample_motion_prior(rng, n, priors, ndim, *, concentration_rng=None):
    """Draws from the per-bin motion prior, in the sampler's (log / logit) coordinates.

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int
        Number of draws.
    priors : Priors
    ndim : int
        4 (unimodal: log A, log T, log s_a, log s_T) or 7 (two-period: log A, log T1,
        log T2, logit w, log s_a, log s_T, log c with T1 < T2).
    concentration_rng : numpy.random.Generator, optional
        Draws ``c`` (two-period) from this generator instead of ``rng``, so that ``rng``'s
        stream is the same as without ``c`` (a campaign's other truths do not move).

    Returns
    -------
    numpy.ndarray, shape (n, ndim)
    """

    def trunc_lognormal(median, sd, lo, hi):
        x = np.exp(rng.normal(np.log(median), sd, size=4 * n + 64))
        x = x[(x > lo) & (x < hi)]
        return x[:n]

    a = trunc_lognormal(
        priors.amplitude_median_deg,
        priors.amplitude_log_sd,
        priors.amplitude_min_deg,
        priors.amplitude_max_deg,
    )
    ts = [
        trunc_lognormal(
            priors.period_median_s, priors.period_log_sd, priors.period_min_s, priors.period_max_s
        )
        for _ in range(2 if ndim == 7 else 1)
    ]
    sc = []
    for _ in range(2):
        x = np.abs(rng.normal(0.0, priors.scatter_scale, size=4 * n + 64))
        sc.append(x[(x > priors.scatter_min) & (x < priors.scatter_max)][:n])
    if ndim == 4:
        return np.column_stack([np.log(a), np.log(ts[0]), np.log(sc[0]), np.log(sc[1])])
    t1, t2 = np.minimum(ts[0], ts[1]), np.maximum(ts[0], ts[1])
    w = rng.beta(priors.weight_beta, priors.weight_beta, size=n)
    if concentration_rng is not None:
        rng = concentration_rng
    c = trunc_lognormal(
        priors.weight_concentration_median,
        priors.weight_concentration_log_sd,
        priors.weight_concentration_min,
        priors.weight_concentration_max,
    )
    return np.column_stack(
        [
            np.log(a),
            np.log(t1),
            np.log(t2),
            np.log(w / (1 - w)),
            np.log(sc[0]),
            np.log(sc[1]),
            np.log(c),
        ]
    )

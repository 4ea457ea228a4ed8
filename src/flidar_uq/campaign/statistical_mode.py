"""Virtual campaign, statistical mode: records drawn from the Bayesian model itself.

The generative model is exactly the one :mod:`flidar_uq.inference` fits (docs/inference.md),
so that simulation-based calibration (:mod:`flidar_uq.validation.sbc`) can check the
sampler and the cut model:

* per bin ``b``: amplitude ``A_b`` (deg), period ``T_b`` (s) or two periods ``T1_b < T2_b``
  with weight ``w_b``, within-bin log-scatter ``s_a``, ``s_T`` of the IMU statistics;
* per record: IMU amplitude ``a_i = A_b exp(s_a e)``; IMU period ``p_i = T_b exp(s_T e')``
  (two-period bins: ``T1_b`` with probability ``w_b``, else ``T2_b``). Roll and pitch
  statistics are ``a_i exp(+-d_i)`` with ``d_i ~ N(0, imu_axis_noise)`` so that their
  geometric mean (the inference's record statistic) is ``a_i`` exactly;
* reference std ``r_i = TI_i m_i``; ``sZ_i`` from the surrogate at ``(m_i, A_b, T_b)``;
  floating-lidar std ``s_i ~ N(mu_i, tau_i)`` with
  ``mu_i = sqrt(r_i^2 + sZ_i^2 + 2 rho r_i sZ_i)`` (Eq. 15 of Gutiérrez-Antuñano et al. (2018)) and
  ``tau_i^2 = (kappa mu_i)^2 + tau0^2``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from flidar_uq.inference import Priors, sample_motion_prior
from flidar_uq.physics.surrogate import default_surrogate
from flidar_uq.physics.variance_laws import sigma_moving_pc
from flidar_uq.seeding import as_seedsequence

_PRIORS = Priors()

__all__ = ["generate_statistical_campaign", "draw_true_params"]


def draw_true_params(n_bins, *, two_period_bins=0, priors: Priors = _PRIORS, rng):
    """Draw campaign parameters from the inference priors.

    Parameters
    ----------
    n_bins : int
        Number of bins.
    two_period_bins : int
        How many of the bins (the last ones) get two-period motion.
    priors : Priors
    rng : numpy.random.Generator

    Returns
    -------
    dict
        ``rho``, ``tau0_ms``, ``kappa`` (floats) and ``bins``: list of dicts with
        ``amplitude_deg``, ``period_s`` (unimodal) or ``period1_s``, ``period2_s``,
        ``weight1``, ``weight_concentration`` (two-period), ``scatter_amplitude``,
        ``scatter_period``.
    """
    if not 0 <= two_period_bins <= n_bins:
        raise ValueError(
            f"draw_true_params: two_period_bins={two_period_bins} not in [0, {n_bins}]"
        )
    # the two-period concentration from its own stream: rng's draws (the other truths) are
    # those of a campaign without it
    rng_c = rng.spawn(1)[0]
    bins = []
    for b in range(n_bins):
        if b >= n_bins - two_period_bins:
            th = sample_motion_prior(rng, 1, priors, 7, concentration_rng=rng_c)[0]
            w = 1.0 / (1.0 + np.exp(-th[3]))
            bins.append(
                {
                    "amplitude_deg": float(np.exp(th[0])),
                    "period1_s": float(np.exp(th[1])),
                    "period2_s": float(np.exp(th[2])),
                    "weight1": float(w),
                    "scatter_amplitude": float(np.exp(th[4])),
                    "scatter_period": float(np.exp(th[5])),
                    "weight_concentration": float(np.exp(th[6])),
                }
            )
        else:
            th = np.exp(sample_motion_prior(rng, 1, priors, 4)[0])
            bins.append(
                {
                    "amplitude_deg": float(th[0]),
                    "period_s": float(th[1]),
                    "scatter_amplitude": float(th[2]),
                    "scatter_period": float(th[3]),
                }
            )
    rho = float(rng.uniform(-1.0, 1.0))
    tau0 = float(abs(rng.normal(0.0, priors.tau0_scale_ms)))
    kappa = float(abs(rng.normal(0.0, priors.kappa_scale)))
    return {
        "rho": rho,
        "tau0_ms": max(tau0, priors.tau0_min_ms),
        "kappa": max(kappa, priors.kappa_min),
        "bins": bins,
    }


def generate_statistical_campaign(
    n_bins: int,
    records_per_bin: int,
    true_params: dict | None = None,
    seed=0,
    *,
    surrogate=None,
    two_period_bins: int = 0,
    hws_range_ms: tuple[float, float] = (4.0, 16.0),
    ti_median: float = 0.08,
    ti_log_sd: float = 0.3,
    imu_axis_noise: float = 0.05,
    height_m: float = 100.0,
    priors: Priors = _PRIORS,
) -> tuple[pd.DataFrame, dict]:
    """Draw a campaign from the Bayesian model with known parameters.

    Parameters
    ----------
    n_bins : int
        Number of bins (>= 1).
    records_per_bin : int
        10-min records per bin (>= 1).
    true_params : dict, optional
        As returned by :func:`draw_true_params`; drawn from the priors when None.
    seed : int or numpy.random.SeedSequence
    surrogate : SigmaZSurrogate, optional
        Default ``get_surrogate()``.
    two_period_bins : int
        Used only when ``true_params`` is None.
    hws_range_ms : (float, float)
        Each bin's centre HWS is uniform in this range (m/s); records within +-0.5 m/s.
    ti_median, ti_log_sd : float
        Log-normal distribution of the true TI (-).
    imu_axis_noise : float
        Log-std of the roll/pitch split of the IMU statistics (-).
    height_m : float
        Measurement height written to the records (m).
    priors : Priors

    Returns
    -------
    records : pandas.DataFrame
        Core record columns (docs/interfaces.md) plus ``bin_id`` and truth columns
        ``true_hws_mean_ms``, ``true_hws_std_ms``, ``true_ti``, ``true_amplitude_deg``,
        ``true_period_s``, ``true_sigma_z_ms``.
    truth : dict
        ``true_params`` as used.

    Raises
    ------
    ValueError
        If the counts are not positive or ``true_params`` has the wrong number of bins.
    """
    if n_bins < 1 or records_per_bin < 1:
        raise ValueError(
            f"generate_statistical_campaign: n_bins={n_bins} and records_per_bin={records_per_bin} must be >= 1"
        )
    surrogate = default_surrogate(surrogate)
    ss = as_seedsequence(seed)
    rng_par, rng_rec = (np.random.default_rng(c) for c in ss.spawn(2))
    if true_params is None:
        true_params = draw_true_params(
            n_bins, two_period_bins=two_period_bins, priors=priors, rng=rng_par
        )
    if len(true_params["bins"]) != n_bins:
        raise ValueError(
            f"generate_statistical_campaign: true_params has {len(true_params['bins'])} bins, n_bins={n_bins}"
        )
    n = records_per_bin
    frames = []
    t0 = pd.Timestamp("2026-01-01T00:00:00Z")
    for b, p in enumerate(true_params["bins"]):
        centre = rng_rec.uniform(*hws_range_ms)
        m = centre + rng_rec.uniform(-0.5, 0.5, n)
        ti = np.exp(rng_rec.normal(np.log(ti_median), ti_log_sd, n))
        r = ti * m
        a = p["amplitude_deg"] * np.exp(p["scatter_amplitude"] * rng_rec.standard_normal(n))
        if "period_s" in p:
            centre_t = np.full(n, p["period_s"])
            sz = surrogate.sigma_z_ms(m, p["amplitude_deg"], p["period_s"])
            per2, w1 = np.full(n, np.nan), np.full(n, np.nan)
            true_t = p["period_s"]
            per = centre_t * np.exp(p["scatter_period"] * rng_rec.standard_normal(n))
            per1 = np.full(n, np.nan)
        else:
            # every record has a two-peaked spectrum of its own (the model of
            # flidar_uq.inference.densities.log_prob_two_period): both peak periods about
            # the bin's, and its share of tilt variance in the short-period peak
            # ~ Beta(w c, (1 - w) c); the record's (roll, pitch) period is its dominant peak's
            c = p["weight_concentration"]
            per1 = p["period1_s"] * np.exp(p["scatter_period"] * rng_rec.standard_normal(n))
            per2 = p["period2_s"] * np.exp(p["scatter_period"] * rng_rec.standard_normal(n))
            w1 = rng_rec.beta(p["weight1"] * c, (1.0 - p["weight1"]) * c, size=n)
            per = np.where(w1 >= 0.5, per1, per2)
            sz = surrogate.sigma_z_two_period_ms(
                m, p["amplitude_deg"], p["period1_s"], p["period2_s"], p["weight1"]
            )
            true_t = p["period1_s"]
        sz = np.asarray(sz, dtype=float)
        mu = sigma_moving_pc(
            r, sz, true_params["rho"]
        )  # Eq. (15) of Gutiérrez-Antuñano et al. (2018)
        tau = np.sqrt((true_params["kappa"] * mu) ** 2 + true_params["tau0_ms"] ** 2)
        s = mu + tau * rng_rec.standard_normal(n)
        while np.any(s <= 0):  # truncate at 0 (a std is positive); negligible mass
            bad = s <= 0
            s[bad] = mu[bad] + tau[bad] * rng_rec.standard_normal(int(bad.sum()))
        d_a = imu_axis_noise * rng_rec.standard_normal(n)
        d_t = imu_axis_noise * rng_rec.standard_normal(n)
        frames.append(
            pd.DataFrame(
                {
                    "timestamp": t0 + pd.to_timedelta(10 * (b * n + np.arange(n)), unit="min"),
                    "height_m": height_m,
                    "hws_mean_ms": m,
                    "hws_std_ms": s,
                    "wd_mean_deg": rng_rec.uniform(0.0, 360.0, n),
                    "availability_pct": 100.0,
                    "roll_amplitude_deg": a * np.exp(d_a),
                    "pitch_amplitude_deg": a * np.exp(-d_a),
                    "roll_period_s": per * np.exp(d_t),
                    "pitch_period_s": per * np.exp(-d_t),
                    "period1_s": per1,
                    "period2_s": per2,
                    "weight1": w1,
                    "ref_hws_mean_ms": m,
                    "ref_hws_std_ms": r,
                    "bin_id": b,
                    "true_hws_mean_ms": m,
                    "true_hws_std_ms": r,
                    "true_ti": ti,
                    "true_amplitude_deg": p["amplitude_deg"],
                    "true_period_s": true_t,
                    "true_sigma_z_ms": sz,
                }
            )
        )
    records = pd.concat(frames, ignore_index=True)
    records["timestamp"] = records["timestamp"].dt.strftime("%Y-%m-%dT%H:%M:%SZ")
    return records, true_params

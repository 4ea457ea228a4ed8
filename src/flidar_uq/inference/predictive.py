"""Prior predictive draws of the floating-lidar std."""

from __future__ import annotations

import numpy as np

from flidar_uq.inference.observations import _default_surrogate
from flidar_uq.inference.priors import Priors, sample_motion_prior
from flidar_uq.physics.variance_laws import sigma_moving_pc
from flidar_uq.seeding import as_seedsequence
from flidar_uq.threads import single_threaded


@single_threaded
def prior_predictive(
    hws_ms, ref_std_ms, *, surrogate=None, priors: Priors = Priors(), ndraws=2000, seed
):
    """Prior predictive draws of the floating-lidar std for given records.

    Parameters
    ----------
    hws_ms, ref_std_ms : array_like, shape (n,)
        Mean HWS and reference std (m/s) of the records.
    surrogate : SigmaZSurrogate, optional
    priors : Priors
    ndraws : int
    seed : int or SeedSequence

    Returns
    -------
    dict of numpy.ndarray
        ``amplitude_deg``, ``period_s``, ``rho``, ``tau0_ms``, ``kappa`` (ndraws,),
        ``sigma_z_ms`` and ``hws_std_ms`` (ndraws, n).
    """
    surrogate = _default_surrogate(surrogate)
    rng = np.random.default_rng(as_seedsequence(seed))
    th = sample_motion_prior(rng, ndraws, priors, 4)
    a, t = np.exp(th[:, 0]), np.exp(th[:, 1])
    rho = rng.uniform(-1, 1, ndraws)
    tau0 = np.abs(rng.normal(0, priors.tau0_scale_ms, ndraws))
    kappa = np.abs(rng.normal(0, priors.kappa_scale, ndraws))
    h = np.asarray(hws_ms, float)[None, :]
    r = np.asarray(ref_std_ms, float)[None, :]
    sz = np.asarray(surrogate.sigma_z_ms(h, a[:, None], t[:, None]), float)
    mu = sigma_moving_pc(r, sz, rho[:, None])
    tau = np.sqrt((kappa[:, None] * mu) ** 2 + tau0[:, None] ** 2)
    s = np.abs(mu + tau * rng.standard_normal(mu.shape))
    return {
        "amplitude_deg": a,
        "period_s": t,
        "rho": rho,
        "tau0_ms": tau0,
        "kappa": kappa,
        "sigma_z_ms": sz,
        "hws_std_ms": s,
    }

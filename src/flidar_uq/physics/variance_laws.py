"""Variance-combination laws of Gutiérrez-Antuñano et al. (2018) (Eqs. 15-17), its rho estimate, and the deployment formula.

Gutiérrez-Antuñano et al. (2018, Sec. 3.2) combines the reference HWS std
``sigma_ref`` and the motion-induced HWS error std ``sigma_Z`` into the std a moving
lidar sees:

* PC (partially correlated, Eq. 15): ``s^2 = r^2 + sZ^2 + 2 rho r sZ``
* U  (uncorrelated, Eq. 16):         ``s = sqrt(r^2 + sZ^2)``
* C  (linearly correlated, Eq. 17):  ``s = r + sZ``

The deployment formula inverts Eq. (15) for the corrected std ``c`` given the
floating-lidar std ``s`` (no reference available):
``c = -rho sZ + sqrt(s^2 - (1 - rho^2) sZ^2)``.
When the discriminant ``s^2 - (1 - rho^2) sZ^2`` is negative the measured std is
smaller than the motion law allows; the formula has no real root. We then return
``c = 0`` (the physically closest admissible value: the whole measured std is
attributed to motion) and raise the ``discriminant_negative`` flag; callers must
report the flag, never drop the record silently.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "sigma_moving_pc",
    "sigma_moving_u",
    "sigma_moving_c",
    "corrected_std",
    "rho_bin_correlation",
]


def sigma_moving_pc(sigma_ref_ms, sigma_z_ms, rho):
    """Std seen by the moving lidar, partially correlated law (Eq. 15 of Gutiérrez-Antuñano et al. (2018)).

    Parameters
    ----------
    sigma_ref_ms : array_like
        Reference 10-min HWS std (m/s), any shape.
    sigma_z_ms : array_like
        Motion-induced HWS error std (m/s), broadcastable.
    rho : array_like
        Correlation between reference HWS and motion error Z (-), in [-1, 1].

    Returns
    -------
    numpy.ndarray
        ``sqrt(r^2 + sZ^2 + 2 rho r sZ)`` (m/s); NaN where an input is negative,
        ``|rho| > 1`` or NaN.
    """
    r = np.asarray(sigma_ref_ms, dtype=float)
    sz = np.asarray(sigma_z_ms, dtype=float)
    rho = np.asarray(rho, dtype=float)
    var = r**2 + sz**2 + 2.0 * rho * r * sz  # Eq. (15) of Gutiérrez-Antuñano et al. (2018)
    ok = (r >= 0) & (sz >= 0) & (np.abs(rho) <= 1.0)
    return np.where(ok, np.sqrt(np.where(ok, np.maximum(var, 0.0), 0.0)), np.nan)


def sigma_moving_u(sigma_ref_ms, sigma_z_ms):
    """Std seen by the moving lidar, uncorrelated law (Eq. 16 of Gutiérrez-Antuñano et al. (2018)), m/s."""
    return sigma_moving_pc(
        sigma_ref_ms, sigma_z_ms, 0.0
    )  # Eq. (16) of Gutiérrez-Antuñano et al. (2018)


def sigma_moving_c(sigma_ref_ms, sigma_z_ms):
    """Std seen by the moving lidar, linearly correlated law (Eq. 17 of Gutiérrez-Antuñano et al. (2018)), m/s."""
    return sigma_moving_pc(
        sigma_ref_ms, sigma_z_ms, 1.0
    )  # Eq. (17) of Gutiérrez-Antuñano et al. (2018): r + sZ


def corrected_std(sigma_moving_ms, sigma_z_ms, rho):
    """Motion-corrected std: the root of Eq. (15) of Gutiérrez-Antuñano et al. (2018) solved for the reference std.

    Parameters
    ----------
    sigma_moving_ms : array_like
        Floating-lidar 10-min HWS std ``s`` (m/s).
    sigma_z_ms : array_like
        Motion-induced HWS error std ``sZ`` (m/s), broadcastable with ``s``.
    rho : array_like
        Correlation (-) in [-1, 1], broadcastable (e.g. one value per posterior draw).

    Returns
    -------
    corrected_ms : numpy.ndarray
        ``c = -rho sZ + sqrt(s^2 - (1 - rho^2) sZ^2)`` (m/s), clipped at 0 from below.
        Where the discriminant is negative, ``c = 0``.
        NaN where an input is NaN, negative, or ``|rho| > 1``.
    discriminant_negative : numpy.ndarray of bool
        True where ``s^2 - (1 - rho^2) sZ^2 < 0`` (no real root; flagged, never hidden),
        or where the larger root is negative (``s < rho sZ`` impossible for ``rho <= 0``;
        for ``rho > 0`` it means ``s < sZ``: motion alone explains more than was measured).
    """
    s = np.asarray(sigma_moving_ms, dtype=float)
    sz = np.asarray(sigma_z_ms, dtype=float)
    rho = np.asarray(rho, dtype=float)
    s, sz, rho = np.broadcast_arrays(s, sz, rho)
    valid = (s >= 0) & (sz >= 0) & (np.abs(rho) <= 1.0)
    disc = s**2 - (1.0 - rho**2) * sz**2  # discriminant of Eq. (15) solved for sigma_ref
    root = -rho * sz + np.sqrt(np.where(valid & (disc > 0), disc, 0.0))
    negative = valid & ((disc < 0) | (root < 0))
    corrected = np.where(valid, np.where(negative, 0.0, np.maximum(root, 0.0)), np.nan)
    return corrected, negative


def rho_bin_correlation(bin_ref_hws_ms, bin_mean_z_ms):
    """Gutiérrez-Antuñano et al.'s (2018) rho: Pearson correlation over bins of (reference HWS, E(Z)) (Sec. 3.2).

    Gutiérrez-Antuñano et al. (2018) computed one (reference HWS, E(Z)) pair per bin (109 bins) and a single
    correlation coefficient from them (rho = 0.78).

    Parameters
    ----------
    bin_ref_hws_ms : array_like, shape (n_bins,)
        Mean reference HWS of each bin (m/s).
    bin_mean_z_ms : array_like, shape (n_bins,)
        Expected motion-induced HWS error E(Z) of each bin (m/s), from the simulator.

    Returns
    -------
    float
        Pearson correlation; NaN if fewer than 3 finite pairs or a constant input.

    Raises
    ------
    ValueError
        If the two inputs do not have the same shape.
    """
    x = np.asarray(bin_ref_hws_ms, dtype=float)
    y = np.asarray(bin_mean_z_ms, dtype=float)
    if x.shape != y.shape:
        raise ValueError(
            f"rho_bin_correlation: bin_ref_hws_ms has shape {x.shape} but bin_mean_z_ms has {y.shape}"
        )
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if x.size < 3:
        return float("nan")
    dx, dy = x - x.mean(), y - y.mean()
    den = np.sqrt(np.sum(dx**2) * np.sum(dy**2))
    if den == 0.0:
        return float("nan")
    return float(np.sum(dx * dy) / den)  # Sec. 3.2 of Gutiérrez-Antuñano et al. (2018)

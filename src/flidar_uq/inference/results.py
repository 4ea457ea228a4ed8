"""Fit results (BinFit, GlobalFit, FailedFit) and their one NetCDF writer and reader."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field

import arviz as az
import numpy as np
import pandas as pd
import xarray as xr

from flidar_uq.inference.loo import _loo
from flidar_uq.inference.observations import (
    _default_surrogate,
    bin_motion_terms,
    effective_sigma_z_ms,
)
from flidar_uq.physics.dbs_sigma_z import dbs_tilt_lever_terms
from flidar_uq.physics.six_dof_sigma_z import translation_unit_sq


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.floating | np.integer | np.bool_):
        return x.item()
    return x


@dataclass
class _FitBase:
    kind = "base"
    draws: dict  # name -> (nensembles, ndraws)
    # (nensembles, ndraws, n_obs); None for a fit read from a file and for a record fit (its
    # PSIS-LOO computed in blocks of records, in ``pointwise_loo``)
    log_lik: np.ndarray | None
    diagnostics: dict
    failure_reasons: list
    info: dict = field(default_factory=dict)
    # PSIS-LOO of the draws' log-likelihood (``_loo``'s dict): computed by the fit (a bin or
    # record fit) or by save_fit (what a file keeps instead of ``log_lik``); None: not yet
    pointwise_loo: dict | None = None

    def loo(self) -> dict | None:
        """PSIS-LOO (``elpd``, ``se``, ``p_loo``, pointwise ``elpd_i``, ``pareto_k``) or None.

        ``pointwise_loo`` when the fit or :func:`save_fit` computed it (a file keeps only
        these, see :func:`save_fit`), else from ``log_lik``.
        """
        if self.pointwise_loo is None and self.log_lik is not None:
            return _loo(np.asarray(self.log_lik))
        return self.pointwise_loo

    @property
    def converged(self) -> bool:
        """True only if every convergence convergence criterion (docs/inference.md) is met."""
        return len(self.failure_reasons) == 0

    def flat(self, name: str) -> np.ndarray:
        """All stored draws of one parameter, shape (nensembles * ndraws,)."""
        return np.asarray(self.draws[name]).reshape(-1)

    def _summary_rows(self, extra):
        rows = []
        for n, d in self.draws.items():
            x = np.asarray(d).ravel()
            q = np.quantile(x, [0.05, 0.5, 0.95])
            rows.append(
                {
                    **extra,
                    "param": n,
                    "mean": float(np.mean(x)),
                    "sd": float(np.std(x)),
                    "q05": q[0],
                    "median": q[1],
                    "q95": q[2],
                    **{k: v for k, v in self.diagnostics.get(n, {}).items()},
                    "converged": self.converged,
                    "failure_reasons": "; ".join(self.failure_reasons),
                }
            )
        return pd.DataFrame(rows)

    def to_datatree(self):
        """ArviZ 1.x DataTree: posterior, log_likelihood (if held), constant_data, and the
        stored PSIS-LOO (group ``pointwise_loo``, if held); diagnostics in attrs."""
        post = {n: np.asarray(v) for n, v in self.draws.items()}
        groups = {
            "posterior": post,
            "constant_data": {k: np.asarray(v) for k, v in self.info.get("constant", {}).items()},
        }
        if self.log_lik is not None:
            groups["log_likelihood"] = {"obs": np.asarray(self.log_lik)}
        dt = az.from_dict(groups)
        if self.pointwise_loo is not None:
            loo = self.pointwise_loo
            dt["pointwise_loo"] = xr.DataTree(
                xr.Dataset(
                    {k: ("obs_dim_0", np.asarray(loo[k], float)) for k in _LOO_ARRAYS},
                    attrs={k: float(loo[k]) for k in _LOO_SCALARS},
                )
            )
        dt.attrs["flidar_uq_kind"] = self.kind
        dt.attrs["converged"] = int(self.converged)
        dt.attrs["failure_reasons"] = json.dumps(self.failure_reasons)
        dt.attrs["diagnostics"] = json.dumps(_jsonable(self.diagnostics))
        meta = {k: v for k, v in self.info.items() if k != "constant"}
        dt.attrs["info"] = json.dumps(_jsonable(meta))
        return dt

    def to_netcdf(self, path) -> None:
        """Write the fit to NetCDF: :func:`save_fit`."""
        save_fit(self, path)


@dataclass
class BinFit(_FitBase):
    """Posterior of one bin's motion parameters (stage 1).

    Attributes
    ----------
    draws : dict
        ``amplitude_deg``, ``period_s`` (``period1_s``, ``period2_s``, ``weight1`` (the
        expected share of a record's tilt variance in the short-period peak) and
        ``weight_concentration`` for the two-period model), ``scatter_amplitude``,
        ``scatter_period``; each (nensembles, ndraws).
    info : dict
        ``bin_id``, ``model`` ("unimodal"/"two_period"), ``n_records``, ``n_imu``,
        ``prior_only`` (no IMU statistics: posterior = prior), ``loo`` (``n_two_peak`` and
        ``two_peak_share``: the bin's IMU records with a two-peaked spectrum of their own,
        which choose the model; elpd and max Pareto k of the chosen model),
        ``constant`` (record_index, hws_mean_ms).
    """

    kind = "bin"

    @property
    def bin_id(self):
        return self.info["bin_id"]

    @property
    def model(self) -> str:
        return self.info["model"]

    def sigma_z_draws(
        self,
        hws_ms,
        surrogate=None,
        *,
        ndraws=None,
        rng=None,
        lever_arm_m=None,
        scan_period_s=1.0,
        wind_body_deg=None,
    ) -> np.ndarray:
        """Draws of sigma_Z (m/s) for records at mean HWS ``hws_ms``.

        The lidar is the surrogate's (``surrogate.lidar``). A CW VAD lidar's sigma_Z is the
        surrogate's (Gutiérrez-Antuñano et al. 2018) with the VAD form of the head
        translation (:func:`translation_unit_sq`). A pulsed DBS lidar's is the quadratic
        form of its own beam-pair phasors (Yamaguchi & Ishihara 2016, Eqs. 3-4;
        :func:`flidar_uq.physics.dbs_sigma_z.dbs_tilt_lever_terms`) at the draw's
        amplitude (roll and pitch alike) and period, with the cross term between the
        tilt leak and the head translation, at the record's wind direction relative to
        the beams; a two-period draw adds its two components' Gram matrices (weights
        ``w`` and ``1 - w`` of the tilt variance).

        Parameters
        ----------
        hws_ms : array_like, shape (n,)
            Records' mean HWS (m/s).
        surrogate : SigmaZSurrogate, optional
            Default ``get_surrogate()``.
        ndraws : int, optional
            Number of posterior draws (random without replacement if fewer than stored;
            all stored draws by default).
        rng : numpy.random.Generator, optional
            Needed when ``ndraws`` subsamples.
        lever_arm_m : float or array_like, shape (ndraws, 1), optional
            Effective lever arm (m) per draw; adds the head translation,
            ``sZ^2 = sZ_rot^2 + L^2 u^2`` (:func:`effective_sigma_z_ms`).
        scan_period_s : float
            A CW lidar's VAD scan duration (s) for the translation term (a DBS lidar uses
            its own beam timing).
        wind_body_deg : array_like, shape (n,), optional
            A DBS lidar's wind direction relative to the body per record
            (:func:`flidar_uq.physics.dbs_sigma_z.wind_to_body_deg`), deg; NaN or None:
            averaged over headings.

        Returns
        -------
        numpy.ndarray, shape (ndraws, n)
        """
        sz, u2, corr = self._motion_draws(
            hws_ms, surrogate, self._draw_index(ndraws, rng), scan_period_s, wind_body_deg
        )
        if lever_arm_m is None:
            return sz
        return effective_sigma_z_ms(sz, u2, lever_arm_m, correlation=corr)

    def _motion_draws(self, hws_ms, surrogate, idx, scan_period_s=1.0, wind_body_deg=None):
        """Rotational sigma_Z draws (ndraws, n), translation units u^2 ((ndraws, 1); a DBS
        lidar's (ndraws, n)) and their correlation (a DBS lidar's (ndraws, n); None for a
        CW lidar), :meth:`sigma_z_draws`."""
        surrogate = _default_surrogate(surrogate)
        hws = np.asarray(hws_ms, dtype=float)[None, :]
        a = self.flat("amplitude_deg")[idx][:, None]
        if self.model == "two_period":
            t1 = self.flat("period1_s")[idx][:, None]
            t2 = self.flat("period2_s")[idx][:, None]
            w = self.flat("weight1")[idx][:, None]
        if surrogate.lidar.kind == "dbs":
            beta = None if wind_body_deg is None else np.asarray(wind_body_deg, float)[None, :]
            if self.model == "two_period":  # the variances of independent components add
                parts = ((a * np.sqrt(w), t1), (a * np.sqrt(1.0 - w), t2))
            else:
                parts = ((a, self.flat("period_s")[idx][:, None]),)
            gram = [
                dbs_tilt_lever_terms(hws, amp, per, wind_body_deg=beta, lidar=surrogate.lidar)
                for amp, per in parts
            ]
            return bin_motion_terms(*(sum(entry) for entry in zip(*gram, strict=True)))
        if self.model == "two_period":
            sz = surrogate.sigma_z_two_period_ms(hws, a, t1, t2, w)
            u2 = w * translation_unit_sq(a, t1, scan_period_s) + (1 - w) * translation_unit_sq(
                a, t2, scan_period_s
            )
        else:
            t = self.flat("period_s")[idx][:, None]
            sz = surrogate.sigma_z_ms(hws, a, t)
            u2 = translation_unit_sq(a, t, scan_period_s)
        return np.asarray(sz, dtype=float), np.asarray(u2, dtype=float), None

    def _draw_index(self, ndraws, rng):
        n = self.flat("amplitude_deg").size
        if ndraws is None or ndraws >= n:
            return np.arange(n)
        if rng is None:
            raise ValueError("BinFit.sigma_z_draws: rng is required when ndraws subsamples")
        return rng.choice(n, size=ndraws, replace=False)

    def summary(self) -> pd.DataFrame:
        """One row per parameter: moments, quantiles, R-hat, ESS, tau, convergence, model, LOO."""
        loo = self.info.get("loo", {})
        extra = {
            "bin_id": self.bin_id,
            "model": self.model,
            "n_records": self.info["n_records"],
            "n_imu": self.info["n_imu"],
            "prior_only": self.info["prior_only"],
            "two_peak_share": loo.get("two_peak_share", np.nan),
            "pareto_k_max": loo.get(f"{self.model}_pareto_k_max", np.nan),
        }
        return self._summary_rows(extra)


@dataclass
class GlobalFit(_FitBase):
    """Posterior of the global parameters ``rho``, ``tau0_ms``, ``kappa`` [, ``lever_arm_m``
    [, ``motion_scale``]] (stage 2).

    ``info`` holds ``n_records`` used, ``excluded_bins`` (bins not converged, never used),
    ``prior_only`` (no reference data), ``loo`` (global vs per-bin rho).
    """

    kind = "global"

    def summary(self) -> pd.DataFrame:
        """One row per parameter with diagnostics and the global-vs-per-bin-rho LOO result."""
        loo = self.info.get("loo", {})
        extra = {
            "n_records": self.info["n_records"],
            "prior_only": self.info["prior_only"],
            "excluded_bins": json.dumps(_jsonable(self.info.get("excluded_bins", []))),
            "elpd_diff_per_bin_rho": loo.get("elpd_diff", np.nan),
            "elpd_diff_se": loo.get("elpd_diff_se", np.nan),
            "pareto_k_max": loo.get("global_pareto_k_max", np.nan),
            "preferred_rho_model": loo.get("preferred", "global"),
            "global_model": loo.get("model", "rho_only"),
            "elpd_diff_lever_arm": loo.get("lever_arm_elpd_diff", np.nan),
            "elpd_diff_lever_arm_se": loo.get("lever_arm_elpd_diff_se", np.nan),
            "elpd_diff_motion_scale": loo.get("lever_arm_scale_elpd_diff", np.nan),
            "elpd_diff_motion_scale_se": loo.get("lever_arm_scale_elpd_diff_se", np.nan),
        }
        return self._summary_rows(extra)


@dataclass(frozen=True)
class FailedFit:
    """A fit that raised instead of returning a result (written by :func:`write_failed_fit`).

    Attributes
    ----------
    bin_id : int or None
        The bin whose fit raised (None if not a bin fit).
    reason : str
        What went wrong (e.g. ``"ValueError: ..."``).
    """

    kind = "failed"
    bin_id: int | None
    reason: str

    @property
    def converged(self) -> bool:
        """Always False: a failed fit has no posterior."""
        return False

    @property
    def failure_reasons(self) -> list:
        return [self.reason]


# wall-clock attributes ArviZ adds: dropped so that reruns write identical bytes
_VOLATILE_ATTRS = ("created_at", "creation_library_version")


# the PSIS-LOO dict of loo._loo: pointwise arrays and scalars
_LOO_ARRAYS = ("elpd_i", "pareto_k")
_LOO_SCALARS = ("elpd", "se", "p_loo")
# lossless compression of every stored variable (HDF5 deflate after byte shuffle)
_COMPRESSION = {"zlib": True, "complevel": 4, "shuffle": True}


def _encoding(dt) -> dict:
    """Per-group NetCDF encoding: every numeric array compressed."""
    enc = {}
    for node in dt.subtree:
        ds = node.to_dataset()
        venc = {
            v: dict(_COMPRESSION)
            for v in [*ds.data_vars, *ds.coords]
            if ds[v].ndim > 0 and ds[v].dtype.kind in "fiu"
        }
        if venc:
            enc[node.path] = venc
    return enc


def save_fit(fit: BinFit | GlobalFit | FailedFit, path) -> None:
    """Write a fit to NetCDF (h5netcdf engine), readable by :func:`load_fit`.

    A :class:`BinFit` / :class:`GlobalFit` is written as its ArviZ DataTree
    (:meth:`~BinFit.to_datatree`) without wall-clock attributes, so a rerun writes the same
    bytes; a :class:`FailedFit` as by :func:`write_failed_fit`.

    Every variable is deflate-compressed (lossless). A fit keeps, instead of its (chain,
    draw, observation) log-likelihood (~180 MB in float64 for the default campaign's global
    fit; 11 MB for a bin of 2,700 records, whose writing took most of the 0.3 s CPU a bin
    file cost), the PSIS-LOO computed from it in float64 (group ``pointwise_loo``:
    ``elpd_i``, ``pareto_k`` per observation; ``elpd``, ``se``, ``p_loo``; the fit's own
    ``pointwise_loo`` when it holds one, as :func:`~flidar_uq.inference.bin_fit.fit_bin`'s
    does, else computed here), which is all the model choice
    (:func:`~flidar_uq.inference.global_fit.select_global_model`) and the report read;
    :meth:`~BinFit.loo` returns the same dict before and after the round trip.
    """
    if isinstance(fit, FailedFit):
        write_failed_fit(path, fit.bin_id, fit.reason)
        return
    if fit.log_lik is not None:
        loo = fit.pointwise_loo if fit.pointwise_loo is not None else fit.loo()
        fit = dataclasses.replace(fit, log_lik=None, pointwise_loo=loo)
    dt = fit.to_datatree()
    for node in dt.subtree:
        for a in _VOLATILE_ATTRS:
            node.attrs.pop(a, None)
    dt.to_netcdf(path, engine="h5netcdf", encoding=_encoding(dt))


def write_failed_fit(path, bin_id, reason_text: str) -> None:
    """Write a "failed" fit (the fit raised) that :func:`load_fit` reads as a :class:`FailedFit`.

    Parameters
    ----------
    path : str or os.PathLike
    bin_id : int or None
        The bin whose fit raised.
    reason_text : str
        What went wrong, e.g. ``f"{type(exc).__name__}: {exc}"``.
    """
    attrs = {"flidar_uq_kind": FailedFit.kind, "status": "error", "message": str(reason_text)}
    if bin_id is not None:
        attrs["bin_id"] = int(bin_id)
    xr.Dataset(attrs=attrs).to_netcdf(path, engine="h5netcdf")


def load_fit(path) -> BinFit | GlobalFit | FailedFit:
    """Read a fit written by :func:`save_fit` or :func:`write_failed_fit`.

    Returns
    -------
    BinFit, GlobalFit or FailedFit
        By the file's ``flidar_uq_kind`` ("bin", "global", "failed").
    """
    dt = xr.open_datatree(path, engine="h5netcdf").load()
    kind = dt.attrs["flidar_uq_kind"]
    if kind == FailedFit.kind:
        bin_id = dt.attrs.get("bin_id")
        return FailedFit(
            bin_id=None if bin_id is None else int(bin_id), reason=str(dt.attrs["message"])
        )
    post = dt["posterior"].to_dataset()
    draws = {n: post[n].values for n in post.data_vars}
    log_lik = None
    if "log_likelihood" in dt.children:
        log_lik = dt["log_likelihood"].to_dataset()["obs"].values
    pointwise_loo = None
    if "pointwise_loo" in dt.children:
        ds = dt["pointwise_loo"].to_dataset()
        pointwise_loo = {k: ds[k].values for k in _LOO_ARRAYS}
        pointwise_loo |= {k: float(ds.attrs[k]) for k in _LOO_SCALARS}
    info = json.loads(dt.attrs["info"])
    if "constant_data" in dt.children:
        cd = dt["constant_data"].to_dataset()
        info["constant"] = {n: cd[n].values for n in cd.data_vars}
    cls = {"bin": BinFit, "global": GlobalFit}[kind]
    return cls(
        draws=draws,
        log_lik=log_lik,
        diagnostics=json.loads(dt.attrs["diagnostics"]),
        failure_reasons=json.loads(dt.attrs["failure_reasons"]),
        info=info,
        pointwise_loo=pointwise_loo,
    )

"""The reference instrument behind a campaign's ``ref_*`` columns: what the corrected TI is
calibrated to (the config's ``reference`` section, docs/lidar-response.md), and the per-record
noise its kind brings into the record fit and the propagation."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import NamedTuple

import numpy as np
import pandas as pd

from flidar_uq.correction import propagation as prop
from flidar_uq.correction.regime_discrepancy import REGIME_DISCREPANCY_PRIOR_SD
from flidar_uq.physics.dbs_sigma_z import wind_to_body_deg
from flidar_uq.physics.lidar import get_lidar
from flidar_uq.physics.lidar_response import lidar_std_ratio
from flidar_uq.physics.lidar_spatial_response import lidar_std_ratio_prior
from flidar_uq.seeding import child_seed

__all__ = ["REFERENCE_KINDS", "Reference", "ReferenceNoise"]

#: The reference kinds (config ``reference.kind``).
REFERENCE_KINDS = ("cup", "sonic", "fixed_lidar", "none")

#: The reference columns whose presence makes ``reference.kind`` required.
_REFERENCE_COLUMNS = ("ref_hws_mean_ms", "ref_hws_std_ms")


@dataclass(frozen=True)
class Reference:
    """The reference instrument, its kind and lidar decided.

    Attributes
    ----------
    kind : str
        "cup" | "sonic" (the point wind), "fixed_lidar" (a motionless lidar) or "none" (no
        reference): the model is calibrated to the floating lidar's motionless std, the
        reference's std times its ratio to it, and the corrected std divided by the
        floating lidar's std ratio to the point wind (:meth:`noise`).
    lidar : str
        The fixed lidar's scan geometry (a lidar name of
        :func:`flidar_uq.physics.lidar.get_lidar`; the floating lidar's when not given).
    lidar_std_ratio_log_sd : float or str
        Prior sd of the log of the lidar-to-point std ratio g (-), or "auto": per record
        from the spatial model (:meth:`ratio_log_sd`).
    sampling_correlation : str or float
        Correlation of the reference lidar's and the floating lidar's sampling errors (-):
        "synchronized" (same scan schedule, ``c`` from the buoy heading) or a number in
        [-1, 1].
    height_m : float, sequence of float or None
        Reference height(s) (m); None: the lidar's heights.
    separation_m : float
        Horizontal distance of the reference from the buoy (m).
    heading_deg : float or None
        The fixed lidar's heading, the yaw of its body x axis (deg, counter-clockwise from
        east, as the record column ``heading_mean_deg``; docs/conventions.md): a DBS
        lidar's response to turbulence depends on the wind's direction against its beams.
        None: unknown (averaged over directions).
    regime_discrepancy_prior_sd : float
        Prior sd of the regime discrepancy on log TI when no reference record can teach it
        (-; :func:`flidar_uq.correction.regime_discrepancy.prior_discrepancy`).
    """

    kind: str = "fixed_lidar"
    lidar: str = "zephir300"
    lidar_std_ratio_log_sd: float | str = prop.LIDAR_STD_RATIO_LOG_SD
    sampling_correlation: str | float = prop.REFERENCE_SAMPLING_CORRELATION
    height_m: float | tuple[float, ...] | None = None
    separation_m: float = 0.0
    heading_deg: float | None = None
    regime_discrepancy_prior_sd: float = REGIME_DISCREPANCY_PRIOR_SD

    @classmethod
    def from_config(
        cls,
        section: Mapping | None,
        *,
        lidar: str,
        virtual_kind: str | None = None,
        virtual_spatial: bool = False,
        record_columns: Sequence[str] | None = None,
    ) -> Reference:
        """The config's ``reference`` section with its kind and lidar decided, or a one-line
        error.

        Parameters
        ----------
        section : mapping or None
            ``config["reference"]``: ``kind`` (None when not set), ``lidar`` (None: the
            floating lidar's type), ``height_m`` (m), ``separation_m`` (m),
            ``lidar_std_ratio_log_sd`` ("auto" or a number, -), ``regime_discrepancy_prior_sd`` (-),
            ``sampling_correlation`` ("auto",
            "synchronized" or a number in [-1, 1], -), ``heading_deg`` (deg; None:
            unknown, or 0 for the virtual campaign's reference lidar, whose beams are those
            of a buoy heading of 0). None: an empty section.
        lidar : str
            The floating lidar's geometry name (config ``campaign.lidar``).
        virtual_kind : str or None
            The virtual campaign's ``reference_instrument`` (source virtual), else None.
        virtual_spatial : bool
            The virtual campaign's turbulence varies across the scan disk
            (``wind.spatial_field``): "auto" takes the spatial model's prior sd of ``log g``
            as for the user's files, not 0.
        record_columns : sequence of str or None
            Columns of the user's record table (source files), else None.

        Returns
        -------
        Reference
            ``kind`` decided ("none" when nothing is known), ``lidar`` the fixed lidar's
            geometry or the floating lidar's, and ``sampling_correlation`` "auto" made
            "synchronized" for the virtual campaign's reference lidar (it scans on the
            floating lidar's schedule) and
            :data:`flidar_uq.correction.propagation.REFERENCE_SAMPLING_CORRELATION` (0)
            for a user's fixed lidar (its own schedule). Resolving a resolved section
            again gives the same reference.

        Raises
        ------
        ValueError
            If the kind is unknown, the records carry ``ref_*`` columns and
            ``reference.kind`` is not set, it contradicts the virtual campaign's
            reference, is "none" with ``ref_*`` columns, or ``reference.lidar`` is not a
            known lidar geometry.
        """
        section = dict(section or {})
        kind = section.get("kind")
        if kind is not None and kind not in REFERENCE_KINDS:
            raise ValueError(
                f"config key reference.kind={kind!r} must be one of {', '.join(REFERENCE_KINDS)}"
            )
        if virtual_kind is not None:
            if kind is not None and kind != virtual_kind:
                raise ValueError(
                    f"config key reference.kind={kind!r} contradicts the virtual campaign's "
                    f"reference_instrument {virtual_kind!r} (leave reference.kind unset)"
                )
            kind = virtual_kind
        elif record_columns is not None:
            has_ref = [c for c in _REFERENCE_COLUMNS if c in record_columns]
            if has_ref and kind is None:
                raise ValueError(
                    f"config key reference.kind is missing: the records carry "
                    f"{', '.join(has_ref)}; set it to cup, sonic or fixed_lidar"
                )
            if has_ref and kind == "none":
                raise ValueError(
                    f"config key reference.kind is 'none' but the records carry "
                    f"{', '.join(has_ref)}"
                )
        ref_lidar = section.get("lidar") or lidar
        try:
            get_lidar(ref_lidar)
        except (KeyError, ValueError):
            raise ValueError(
                f"config key reference.lidar={ref_lidar!r} is not a known lidar geometry"
            ) from None
        # the two lidars' sampling correlation: the virtual campaign's reference lidar scans
        # on the floating lidar's schedule; a user's fixed lidar on its own
        corr = section.get("sampling_correlation", "auto")
        if corr == "auto":
            corr = (
                prop.SYNCHRONIZED
                if virtual_kind is not None
                else prop.REFERENCE_SAMPLING_CORRELATION
            )
        # the prior sd of log g: auto is 0 for the virtual campaign whose turbulence is
        # uniform in space (the temporal g is exact), else the spatial model's per record
        g_log_sd = section.get("lidar_std_ratio_log_sd", "auto")
        if g_log_sd == "auto" and virtual_kind is not None and not virtual_spatial:
            g_log_sd = 0.0
        height = section.get("height_m")
        heading = section.get("heading_deg")
        if heading is None and virtual_kind is not None:
            heading = 0.0  # the virtual reference lidar: the beams of a buoy heading of 0
        return cls(
            kind=kind or "none",
            lidar=ref_lidar,
            lidar_std_ratio_log_sd=g_log_sd if g_log_sd == "auto" else float(g_log_sd),
            sampling_correlation=corr,
            height_m=tuple(height) if isinstance(height, list | tuple) else height,
            separation_m=float(section.get("separation_m") or 0.0),
            heading_deg=None if heading is None else float(heading),
            regime_discrepancy_prior_sd=float(
                section.get("regime_discrepancy_prior_sd", REGIME_DISCREPANCY_PRIOR_SD)
            ),
        )

    def to_config(self) -> dict:
        """The resolved section as plain values (a Snakemake rule's params);
        :meth:`from_config` of it gives this reference back."""
        out = asdict(self)
        if isinstance(out["height_m"], tuple):
            out["height_m"] = list(out["height_m"])
        return out

    def noise(
        self,
        records: pd.DataFrame,
        *,
        heights_in_turn: int,
        refocus_delay_s: Sequence[float],
        point_sample_interval_s: float,
        turbulence_dt_s: float | None,
        seed: int,
        lidar: str | None = None,
    ) -> ReferenceNoise:
        """The point target and the two lidars' sampling terms, per record.

        One method for the record fit (``fit_global_model``, model "record") and the
        propagation, so both see the same numbers for a record.

        A motionless lidar's 10-min std is ``g`` times the point std
        (:func:`flidar_uq.physics.lidar_response.lidar_std_ratio`), scattered by its
        sampling (``sd``, :func:`~flidar_uq.physics.lidar_response.lidar_point_log_sd`).
        A DBS lidar's ``g`` and ``sd`` depend on the wind's direction against its beams:
        the floating lidar's from the record's ``wd_mean_deg`` and ``heading_mean_deg``,
        the fixed lidar's from ``wd_mean_deg`` and :attr:`heading_deg`
        (:func:`flidar_uq.physics.dbs_sigma_z.wind_to_body_deg`); unknown: averaged. The
        corrected std is the floating lidar's motionless one, so the point target is the
        floating lidar's ``g_f`` and ``sd_f``; the reference's std is ``g_r / g_f`` times
        the floating lidar's motionless std in expectation, and the pair's sampling
        scatter is ``sd_f^2 + sd_r^2 - 2 c sd_f sd_r`` (``c`` the two lidars' sampling
        correlation). For one conical-scan type ``g_f = g_r``, ``sd_f = sd_r``. A cup or
        sonic measures the point wind: ``g_r = 1``, ``sd_r = 0``, so its std is ``1 / g_f``
        times the floating lidar's motionless std and the pair's scatter is ``sd_f`` (the
        record fit takes it as known; a fit on the point std itself would leave the
        motionless lidar's excess over the point, ``g_f^2 - 1`` of the variance, 3-10 % for
        a DBS lidar, to the motion terms).

        Parameters
        ----------
        records : pandas.DataFrame
            Records with ``hws_mean_ms`` (m/s), ``height_m`` (m) and, where known,
            ``wd_mean_deg`` and ``heading_mean_deg`` (deg).
        heights_in_turn, refocus_delay_s, point_sample_interval_s, turbulence_dt_s
            The lidar's scan settings (-, s, s, s;
            :func:`flidar_uq.correction.propagation.point_target`).
        seed : int
            Config ``inference.seed``.
        lidar : str, optional
            The floating lidar's geometry name (config ``campaign.lidar``); default
            :attr:`lidar` (the same type).

        Returns
        -------
        ReferenceNoise
        """
        floating = self.lidar if lidar is None else lidar
        hws = records["hws_mean_ms"].to_numpy(dtype=float)
        height = records["height_m"].to_numpy(dtype=float)
        scan = {
            "heights_in_turn": int(heights_in_turn),
            "refocus_delay_s": tuple(refocus_delay_s),
            "point_sample_interval_s": point_sample_interval_s,
            "turbulence_dt_s": turbulence_dt_s,
        }
        wd = _column(records, "wd_mean_deg")
        beta_f = wind_to_body_deg(wd, _column(records, "heading_mean_deg"))
        if self.kind in ("cup", "sonic", "none"):
            g_f, sd_f = prop.point_target(
                hws, height, floating, **scan, seed=seed, wind_body_deg=beta_f
            )
            if self.kind == "none":
                return ReferenceNoise(g_f, sd_f, None, None, None)
            # a point reference: no sampling scatter of its own against the point wind, so
            # the pair's is the floating lidar's (c does not enter) and its std is 1 / g_f
            # times the floating lidar's motionless std in expectation
            return ReferenceNoise(g_f, sd_f, np.zeros_like(sd_f), sd_f, 1.0 / g_f)
        beta_r = wind_to_body_deg(wd, np.nan if self.heading_deg is None else self.heading_deg)
        (g_f, sd_f), (g_r, sd_r) = _two_lidar_targets(
            (floating, beta_f), (self.lidar, beta_r), hws, height, scan, seed
        )
        heading = (
            records["heading_mean_deg"].to_numpy(dtype=float)
            if "heading_mean_deg" in records
            else None
        )
        if heading is not None and self.heading_deg is not None:
            heading = heading - self.heading_deg  # the beams' offset between the lidars
        corr = prop.pair_sampling_correlation(
            self.sampling_correlation,
            heading,
            hws,
            height,
            self.lidar,
            seed=int(child_seed(seed, 3).generate_state(1)[0]),
            **scan,
        )
        pair = np.sqrt(np.maximum(sd_f**2 + sd_r**2 - 2.0 * corr * sd_f * sd_r, 0.0))
        return ReferenceNoise(g_f, sd_f, corr, pair, g_r / g_f)

    def ratio_log_sd(self, records: pd.DataFrame, *, lidar: str | None = None):
        """Prior sd of ``log g`` (-): :attr:`lidar_std_ratio_log_sd`, or for "auto" per record
        the root-mean-square distance of the spatial model's ``log g`` over its turbulence
        models from the temporal ``log g`` (:func:`flidar_uq.physics.lidar_spatial_response.
        lidar_std_ratio_prior`, ``sqrt(sd^2 + (mean - log g_temporal)^2)``).

        The lidar is the one whose ratio turns the calibrated std into the point std: the
        fixed lidar for ``fixed_lidar`` (the fit maps the floating lidar onto it), the
        floating lidar (``lidar``, default :attr:`lidar`) for ``none``.

        Parameters
        ----------
        records : pandas.DataFrame
            Records with ``hws_mean_ms`` (m/s) and ``height_m`` (m).
        lidar : str, optional
            The floating lidar's geometry name; default :attr:`lidar`.

        Returns
        -------
        float or numpy.ndarray
            The number, or (n_records,) values >= 0 (0 where a record's speed or height is
            not positive).
        """
        if self.lidar_std_ratio_log_sd != "auto":
            return float(self.lidar_std_ratio_log_sd)
        which = self.lidar if self.kind == "fixed_lidar" or lidar is None else lidar
        hws = records["hws_mean_ms"].to_numpy(dtype=float)
        height = records["height_m"].to_numpy(dtype=float)
        mean, sd = lidar_std_ratio_prior(hws, height, which)
        distance = np.hypot(sd, mean - np.log(lidar_std_ratio(hws, height, which)))
        return np.where(np.isfinite(distance), distance, 0.0)

    def height_label(self) -> str:
        """The reference height(s) as results/ti/metrics.csv writes them: ``;``-joined
        values (m), or "lidar" (the lidar's heights)."""
        if self.height_m is None:
            return "lidar"
        return ";".join(f"{h:g}" for h in np.atleast_1d(self.height_m))


class ReferenceNoise(NamedTuple):
    """:meth:`Reference.noise` of records (arrays of shape (n_records,), or None).

    Attributes
    ----------
    lidar_std_ratio, point_log_sd : numpy.ndarray
        The point target (:class:`flidar_uq.correction.propagation.PointTarget`): the
        floating lidar's motionless std over the point std ``g_f`` (-) and the std of its
        log ``sd_f`` (-), at each record's wind direction against its beams.
    correlation : numpy.ndarray or None
        The reference's sampling correlation with the floating lidar ``c`` (-; 0 for a cup
        or sonic, which has no sampling scatter of its own); None without a reference.
    pair_log_sd : numpy.ndarray or None
        The std of ``log(floating lidar's motionless std / reference's std)`` their
        sampling gives (-; ``sd_f`` for a cup or sonic): the record fit's known pair term
        (``fit_record_model(pair_log_sd=...)``).
    reference_std_ratio : numpy.ndarray or None
        The reference's std over the floating lidar's motionless std in expectation,
        ``g_r / g_f`` (-; 1 for two lidars of one conical-scan type, ``1 / g_f`` for a cup
        or sonic): :meth:`floating_reference` divides the reference std by it for the
        record fit.
    """

    lidar_std_ratio: np.ndarray | None
    point_log_sd: np.ndarray | None
    correlation: np.ndarray | None
    pair_log_sd: np.ndarray | None
    reference_std_ratio: np.ndarray | None

    def floating_reference(self, records: pd.DataFrame) -> pd.DataFrame:
        """``records`` with ``ref_hws_std_ms`` (m/s) divided by :attr:`reference_std_ratio`:
        what the floating lidar would measure motionless where the reference measured, the
        ``r`` of the record fit; the records themselves without a reference lidar."""
        if self.reference_std_ratio is None or "ref_hws_std_ms" not in records:
            return records
        r = records["ref_hws_std_ms"].to_numpy(dtype=float)
        return records.assign(ref_hws_std_ms=r / self.reference_std_ratio)


def _column(records: pd.DataFrame, name: str) -> np.ndarray:
    """A record column as floats, NaN where the table lacks it."""
    if name in records:
        return records[name].to_numpy(dtype=float)
    return np.full(len(records), np.nan)


def _two_lidar_targets(first, second, hws_ms, height_m, scan, seed):
    """:func:`flidar_uq.correction.propagation.point_target` of two lidars, each
    ``(geometry name, wind body directions (deg))``, at the same records: one simulation
    when the two are of one type (same random numbers for both)."""
    (lid_a, beta_a), (lid_b, beta_b) = first, second
    if lid_a == lid_b:
        g, sd = prop.point_target(
            np.concatenate([hws_ms, hws_ms]),
            np.concatenate([height_m, height_m]),
            lid_a,
            **scan,
            seed=seed,
            wind_body_deg=np.concatenate([beta_a, beta_b]),
        )
        n = len(hws_ms)
        return (g[:n], sd[:n]), (g[n:], sd[n:])
    return tuple(
        prop.point_target(hws_ms, height_m, lid, **scan, seed=seed, wind_body_deg=beta)
        for lid, beta in (first, second)
    )

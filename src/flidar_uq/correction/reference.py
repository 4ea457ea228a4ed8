"""The reference instrument behind a campaign's ``ref_*`` columns: what the corrected TI is
calibrated to (the config's ``reference`` section, docs/lidar-response.md), and the per-record
noise its kind brings into the record fit and the propagation."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd

from flidar_uq.correction import propagation as prop
from flidar_uq.physics.lidar import get_lidar
from flidar_uq.seeding import child_seed

__all__ = ["REFERENCE_KINDS", "Reference"]

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
        "cup" | "sonic" (the model is calibrated to the point wind directly),
        "fixed_lidar" (to a motionless lidar, then divided by its std ratio to the point
        wind) or "none" (no reference: a motionless lidar of the floating lidar's type).
    lidar : str
        The fixed lidar's scan geometry (a lidar name of
        :func:`flidar_uq.physics.lidar.get_lidar`; the floating lidar's when not given).
    lidar_std_ratio_log_sd : float
        Prior sd of the log of the lidar-to-point std ratio g (-).
    sampling_correlation : str or float
        Correlation of the reference lidar's and the floating lidar's sampling errors (-):
        "synchronized" (same scan schedule, ``c`` from the buoy heading) or a number in
        [-1, 1].
    height_m : float, sequence of float or None
        Reference height(s) (m); None: the lidar's heights.
    separation_m : float
        Horizontal distance of the reference from the buoy (m).
    """

    kind: str = "fixed_lidar"
    lidar: str = "zephir300"
    lidar_std_ratio_log_sd: float = prop.LIDAR_STD_RATIO_LOG_SD
    sampling_correlation: str | float = prop.REFERENCE_SAMPLING_CORRELATION
    height_m: float | tuple[float, ...] | None = None
    separation_m: float = 0.0

    @classmethod
    def from_config(
        cls,
        section: Mapping | None,
        *,
        lidar: str,
        virtual_kind: str | None = None,
        record_columns: Sequence[str] | None = None,
    ) -> Reference:
        """The config's ``reference`` section with its kind and lidar decided, or a one-line
        error.

        Parameters
        ----------
        section : mapping or None
            ``config["reference"]``: ``kind`` (None when not set), ``lidar`` (None: the
            floating lidar's type), ``height_m`` (m), ``separation_m`` (m),
            ``lidar_std_ratio_log_sd`` (-), ``sampling_correlation`` ("auto",
            "synchronized" or a number in [-1, 1], -). None: an empty section.
        lidar : str
            The floating lidar's geometry name (config ``campaign.lidar``).
        virtual_kind : str or None
            The virtual campaign's ``reference_instrument`` (source virtual), else None.
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
        height = section.get("height_m")
        return cls(
            kind=kind or "none",
            lidar=ref_lidar,
            lidar_std_ratio_log_sd=float(
                section.get("lidar_std_ratio_log_sd", prop.LIDAR_STD_RATIO_LOG_SD)
            ),
            sampling_correlation=corr,
            height_m=tuple(height) if isinstance(height, list | tuple) else height,
            separation_m=float(section.get("separation_m") or 0.0),
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
    ):
        """The reference's point target and the two lidars' sampling pair term, per record.

        One method for the record fit (``fit_global_model``, model "record") and the
        propagation, so both see the same numbers for a record.

        Parameters
        ----------
        records : pandas.DataFrame
            Records with ``hws_mean_ms`` (m/s), ``height_m`` (m) and, for a synchronised
            reference lidar, ``heading_mean_deg`` (deg).
        heights_in_turn, refocus_delay_s, point_sample_interval_s, turbulence_dt_s
            The lidar's scan settings (-, s, s, s;
            :func:`flidar_uq.correction.propagation.point_target`).
        seed : int
            Config ``inference.seed``.

        Returns
        -------
        lidar_std_ratio, point_log_sd : numpy.ndarray or None
            :func:`flidar_uq.correction.propagation.reference_target` (None for a cup or
            sonic).
        correlation, pair_log_sd : numpy.ndarray or None
            For a fixed reference lidar: ``c`` of
            :func:`flidar_uq.correction.propagation.pair_sampling_correlation` (-) and the
            pair term ``sqrt(2 (1 - c)) sd`` (-) of
            :func:`flidar_uq.correction.propagation.reference_pair_log_sd`; else None.
        """
        hws = records["hws_mean_ms"].to_numpy(dtype=float)
        height = records["height_m"].to_numpy(dtype=float)
        scan = {
            "heights_in_turn": int(heights_in_turn),
            "refocus_delay_s": tuple(refocus_delay_s),
            "point_sample_interval_s": point_sample_interval_s,
            "turbulence_dt_s": turbulence_dt_s,
        }
        g_ratio, log_sd = prop.reference_target(
            self.kind, hws, height, self.lidar, **scan, seed=seed
        )
        if self.kind != "fixed_lidar":
            return g_ratio, log_sd, None, None
        heading = (
            records["heading_mean_deg"].to_numpy(dtype=float)
            if "heading_mean_deg" in records
            else None
        )
        corr = prop.pair_sampling_correlation(
            self.sampling_correlation,
            heading,
            hws,
            height,
            self.lidar,
            seed=int(child_seed(seed, 3).generate_state(1)[0]),
            **scan,
        )
        return g_ratio, log_sd, corr, prop.reference_pair_log_sd(log_sd, corr)

    def height_label(self) -> str:
        """The reference height(s) as results/ti/metrics.csv writes them: ``;``-joined
        values (m), or "lidar" (the lidar's heights)."""
        if self.height_m is None:
            return "lidar"
        return ";".join(f"{h:g}" for h in np.atleast_1d(self.height_m))

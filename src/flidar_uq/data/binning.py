"""HWS x motion amplitude x period bins and the bin table (Gutiérrez-Antuñano et al., 2018, Sec. 3.1, Table 1).

Binning variables (Gutiérrez-Antuñano et al., 2018, Secs. 2.4 and 3.1): the 10-min mean HWS, the motion
amplitude (mean of roll and pitch amplitude) and the motion period (mean of roll
and pitch period).  Bins are ``width`` wide and centred on integer multiples of
``width``: with width 1 the edges are [0.5, 1.5), [1.5, 2.5), ... as in the seed.

Each bin has a stable text id ``H08_A03_T04`` (centres; a fractional centre is
written ``H08p5``).  The bin table is sorted by decreasing count with Gutiérrez-Antuñano et al. (2018)
Table 1's columns (``case_no``, ``hws_ms``, ``amplitude_deg``, ``period_s``,
``count``).  Bins with fewer than ``min_count`` records are kept and flagged
(``below_min_count``), never dropped; records lacking a binning variable get no
bin (``bin_id`` missing, ``case_no`` -1) and are counted in ``table.attrs``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

__all__ = [
    "add_harmonic_motion",
    "assign_batches",
    "bin_centre",
    "bin_label",
    "bin_records",
    "bins_for_fitting",
    "speed_bin_ms",
]


def add_harmonic_motion(records: pd.DataFrame) -> pd.DataFrame:
    """Add the Gutiérrez-Antuñano et al. (2018) single motion description to each record.

    ``amplitude_deg`` = mean of roll and pitch amplitude and ``period_s`` = mean
    of roll and pitch period (Gutiérrez-Antuñano et al., 2018, Sec. 2.4).

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``roll_amplitude_deg``, ``pitch_amplitude_deg``,
        ``roll_period_s``, ``pitch_period_s``.

    Returns
    -------
    pandas.DataFrame
        A copy with ``amplitude_deg`` (deg) and ``period_s`` (s) added.
    """
    need = ["roll_amplitude_deg", "pitch_amplitude_deg", "roll_period_s", "pitch_period_s"]
    missing = [c for c in need if c not in records.columns]
    if missing:
        raise ValueError(f"add_harmonic_motion: records lack column(s) {missing}")
    out = records.copy()
    out["amplitude_deg"] = 0.5 * (
        records[need[0]] + records[need[1]]
    )  # Gutiérrez-Antuñano et al. (2018), Sec. 2.4
    out["period_s"] = 0.5 * (
        records[need[2]] + records[need[3]]
    )  # Gutiérrez-Antuñano et al. (2018), Sec. 2.4
    return out


def bin_centre(x, width: float) -> np.ndarray:
    """Centre of the bin holding ``x``: ``floor(x / width + 0.5) * width``.

    Parameters
    ----------
    x : array_like
        Values (any unit); NaN stays NaN.
    width : float
        Bin width, same unit, > 0.

    Returns
    -------
    numpy.ndarray
        Bin centres, same unit; bins are ``[c - width/2, c + width/2)``.
    """
    if not width > 0:
        raise ValueError(f"bin_centre: width must be > 0, got {width!r}")
    return np.floor(np.asarray(x, dtype=np.float64) / width + 0.5) * width


def speed_bin_ms(hws_ms, width_ms: float = 1.0) -> np.ndarray:
    """Wind-speed bin of each HWS: the one speed-bin rule of the package.

    Bins are centred on integer multiples of the width (IEC 61400-12-1 convention):
    ``floor(hws / width + 0.5) * width``, bin ``[c - width/2, c + width/2)``, so a value
    exactly on an edge (e.g. 8.5 m/s at width 1) goes to the upper bin.

    Parameters
    ----------
    hws_ms : array_like
        Horizontal wind speeds, m/s; NaN stays NaN.
    width_ms : float
        Bin width, m/s, > 0 (default 1).

    Returns
    -------
    numpy.ndarray
        Bin centres, m/s, shape of ``hws_ms``.
    """
    return bin_centre(hws_ms, width_ms)


def _fmt(prefix: str, c: float) -> str:
    whole = int(np.floor(c + 1e-9))
    frac = c - whole
    text = f"{prefix}{whole:02d}"
    if frac > 1e-9:
        text += "p" + f"{frac:.6f}".rstrip("0")[2:]
    return text


def bin_label(hws_ms: float, amplitude_deg: float, period_s: float) -> str:
    """Stable bin id from the bin centres, e.g. ``bin_label(8, 3, 4) == "H08_A03_T04"``."""
    return f"{_fmt('H', hws_ms)}_{_fmt('A', amplitude_deg)}_{_fmt('T', period_s)}"


def bin_records(
    records: pd.DataFrame,
    *,
    hws_width_ms: float = 1.0,
    amplitude_width_deg: float = 1.0,
    period_width_s: float = 1.0,
    min_count: int = 3,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Assign records to HWS x amplitude x period bins and build the bin table.

    Parameters
    ----------
    records : pandas.DataFrame
        Records with ``hws_mean_ms`` and roll/pitch amplitude and period columns
        (``amplitude_deg``/``period_s`` are computed if absent, Gutiérrez-Antuñano et al. (2018), Sec. 2.4).
    hws_width_ms, amplitude_width_deg, period_width_s : float
        Bin widths, m/s, deg, s (1 each, Gutiérrez-Antuñano et al. (2018), Sec. 3.1).
    min_count : int
        Bins with fewer records get ``below_min_count = True`` (kept, not dropped).

    Returns
    -------
    assigned : pandas.DataFrame
        Copy of ``records`` with ``amplitude_deg``, ``period_s``, ``hws_bin_ms``,
        ``amplitude_bin_deg``, ``period_bin_s``, ``bin_id`` (text; missing if a
        variable is NaN), ``case_no`` (-1 if unbinned) and ``below_min_count``.
    table : pandas.DataFrame
        One row per occupied bin, sorted by decreasing ``count`` (ties: increasing
        HWS, amplitude, period): ``case_no`` (1 = most frequent), ``bin_id``,
        ``hws_ms``, ``amplitude_deg``, ``period_s`` (centres), ``count``,
        ``below_min_count``.  ``table.attrs`` holds ``n_records``, ``n_binned``,
        ``n_unbinned``, the widths and ``min_count``.
    """
    if int(min_count) < 1:
        raise ValueError(f"bin_records: min_count must be >= 1, got {min_count!r}")
    out = records.copy()
    if "amplitude_deg" not in out.columns or "period_s" not in out.columns:
        out = add_harmonic_motion(out)
    widths = (hws_width_ms, amplitude_width_deg, period_width_s)
    values = (out["hws_mean_ms"], out["amplitude_deg"], out["period_s"])
    centres = [speed_bin_ms(values[0].to_numpy(dtype=np.float64), widths[0])] + [
        bin_centre(v.to_numpy(dtype=np.float64), w)
        for v, w in zip(values[1:], widths[1:], strict=True)
    ]
    out["hws_bin_ms"], out["amplitude_bin_deg"], out["period_bin_s"] = centres
    ok = np.isfinite(np.column_stack(centres)).all(axis=1)
    # integer bin indices -> one int64 key per record (no per-record strings)
    idx = [np.rint(c[ok] / w).astype(np.int64) for c, w in zip(centres, widths, strict=True)]
    lo = [i.min() if i.size else 0 for i in idx]
    span = [int(i.max() - m + 1) if i.size else 1 for i, m in zip(idx, lo, strict=True)]
    key = ((idx[0] - lo[0]) * span[1] + (idx[1] - lo[1])) * span[2] + (idx[2] - lo[2])
    uniq, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    k2 = uniq % span[2] + lo[2]
    k1 = (uniq // span[2]) % span[1] + lo[1]
    k0 = uniq // (span[2] * span[1]) + lo[0]
    table = pd.DataFrame(
        {
            "hws_ms": k0 * hws_width_ms,
            "amplitude_deg": k1 * amplitude_width_deg,
            "period_s": k2 * period_width_s,
            "count": counts.astype(np.int64),
        }
    )
    table["bin_id"] = [
        bin_label(h, a, t)
        for h, a, t in zip(table["hws_ms"], table["amplitude_deg"], table["period_s"], strict=True)
    ]
    order = np.lexsort(
        (table["period_s"], table["amplitude_deg"], table["hws_ms"], -table["count"])
    )
    rank = np.empty(len(table), dtype=np.int64)
    rank[order] = np.arange(1, len(table) + 1)
    table["case_no"] = rank
    table["below_min_count"] = table["count"] < int(min_count)
    case = np.full(len(out), -1, dtype=np.int64)
    case[ok] = rank[inverse.ravel()]
    codes = np.full(len(out), -1, dtype=np.int64)
    codes[ok] = inverse.ravel()
    # categorical: one string per bin, not per record (-1 code = missing)
    ids = pd.Categorical.from_codes(codes, categories=table["bin_id"].to_numpy())
    below = np.zeros(len(out), dtype=bool)
    below[ok] = table["below_min_count"].to_numpy()[inverse.ravel()]
    out["bin_id"] = ids
    out["case_no"] = case
    out["below_min_count"] = below
    table = table.iloc[order][
        ["case_no", "bin_id", "hws_ms", "amplitude_deg", "period_s", "count", "below_min_count"]
    ].reset_index(drop=True)
    table.attrs.update(
        n_records=len(out),
        n_binned=int(ok.sum()),
        n_unbinned=int((~ok).sum()),
        hws_width_ms=hws_width_ms,
        amplitude_width_deg=amplitude_width_deg,
        period_width_s=period_width_s,
        min_count=int(min_count),
    )
    return out, table


def assign_batches(counts: Sequence[int], nbatches: int) -> np.ndarray:
    """Spread bins over ``nbatches`` batch jobs, balancing record counts (greedy, deterministic).

    Parameters
    ----------
    counts : sequence of int, shape (n_bins,)
        Records per bin (the cost proxy of a fit).
    nbatches : int
        Number of batch jobs (>= 1).

    Returns
    -------
    numpy.ndarray of int, shape (n_bins,)
        Batch index of each bin, in ``[0, nbatches)``.

    Raises
    ------
    ValueError
        If ``nbatches < 1``.
    """
    if nbatches < 1:
        raise ValueError(f"assign_batches: nbatches must be >= 1, got {nbatches}")
    counts = np.asarray(counts, dtype=float)
    load = np.zeros(nbatches)
    batch = np.zeros(counts.size, dtype=int)
    # longest-processing-time first; stable sort so ties keep bin order
    for i in np.argsort(-counts, kind="stable"):
        b = int(np.argmin(load))
        batch[i] = b
        load[b] += counts[i] + 1.0  # +1: fixed per-fit overhead
    return batch


def bins_for_fitting(
    records: pd.DataFrame,
    *,
    hws_width_ms: float,
    amplitude_width_deg: float,
    period_width_s: float,
    min_count: int,
    nbatches: int,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The bins the bin model fits: :func:`bin_records` with integer bin ids and batches.

    The integer case number (1 = most frequent bin) becomes ``bin_id`` (file names,
    seeds) and the text id ``bin_label``; bins with at least ``min_count`` records are
    ``fitted`` and spread over ``nbatches`` batch jobs (:func:`assign_batches`).

    Parameters
    ----------
    records : pandas.DataFrame
        Kept records with ``hws_mean_ms`` (m/s), ``amplitude_deg`` (deg) and
        ``period_s`` (s) (:func:`add_harmonic_motion`).
    hws_width_ms, amplitude_width_deg, period_width_s : float
        Bin widths, m/s, deg and s.
    min_count : int
        Fewest records of a fitted bin.
    nbatches : int
        Number of batch jobs (>= 1).

    Returns
    -------
    assigned : pandas.DataFrame
        The binned records (``bin_id`` >= 1, ``bin_label``), index reset.
    table : pandas.DataFrame
        The bin table (:func:`bin_records`) with ``bin_id``, ``bin_label``, ``fitted``
        and ``batch`` (-1: not fitted).
    """
    assigned, table = bin_records(
        records,
        hws_width_ms=hws_width_ms,
        amplitude_width_deg=amplitude_width_deg,
        period_width_s=period_width_s,
        min_count=min_count,
    )
    # integer case number as the pipeline's bin id (file names, seeds); text label kept
    table = table.rename(columns={"bin_id": "bin_label", "case_no": "bin_id"}).reset_index(
        drop=True
    )
    assigned = assigned.rename(columns={"bin_id": "bin_label", "case_no": "bin_id"})
    assigned = assigned[assigned["bin_id"] > 0].reset_index(drop=True)
    table["fitted"] = ~table["below_min_count"].astype(bool)
    table["batch"] = -1
    fitted = table["fitted"].to_numpy()
    table.loc[fitted, "batch"] = assign_batches(table.loc[fitted, "count"].to_numpy(), nbatches)
    return assigned, table

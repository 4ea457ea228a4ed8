"""sigma_Z of pulsed DBS lidars on a moving hull: four studies, one ``--study`` a run.

- ``--study replay`` (the default): the record model's description against LOS-level replay;
  ``--check`` exits 1 unless every ``record`` and ``components`` ratio is within 5 %.
  Writes ``benchmarks/results/dbs_sigma_z.csv``, ``dbs_sigma_z_heading_average.csv`` and
  ``dbs_sigma_z.png``.
- ``--study second-order``: what the first-order harmonic sum leaves out. Writes
  ``dbs_sigma_z_second_order.csv`` and ``.png``.
- ``--study mechanisms``: each mechanism's share of sigma_Z on typical seas. Writes
  ``dbs_mechanisms.csv`` and ``.png``.
- ``--study output-sampling``: one wind a cycle or at every beam: the realised motion error's
  spread about the record model, by swell period. Writes ``dbs_output_sampling.csv`` and
  ``.png``.

Run:  ``PYTHONPATH=src OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/dbs_sigma_z.py
[--study replay|second-order|mechanisms|output-sampling] [--check]``

``--study replay``: sigma_Z of a pulsed DBS lidar on a moving hull: the record model's description against replay.

For each DBS lidar (``windcube_v2``, ``windcube_v1``, ``windcube_v2_1``), sea (a JONSWAP
wind sea, a short wind sea, wind sea plus a swell across or against the wind, a swell alone
across the wind: a "heaving sea"), hull (``wave_follower``, ``discus_buoy``,
``rotation_only``), heading (the wind blowing towards 0, 45, ..., 315 deg from the body x
axis: along a beam or between two) and HWS (5, 10, 15 m/s), with the head 2 m above the
rotation centre, ``REPLAY_N_REC`` ten-minute records of the six-degree-of-freedom motion of
:func:`flidar_uq.physics.seastate.hull_motion_series`:

- ``replay``: realised sigma_Z, the motion replayed line of sight by line of sight through
  the scan simulator with the DBS geometry, each beam's radial speed the mean over its
  dwell (the pulse accumulation, as the virtual campaign and the instrument;
  :func:`flidar_uq.physics.dbs_sigma_z.dbs_replay_sigma_z_ms` with ``dwell_samples``): the
  reference;
- ``components``: the harmonic sum :func:`flidar_uq.physics.dbs_sigma_z.dbs_harmonic_sigma_z_ms`
  over the realised Fourier components (amplitude, period, direction), the first-order
  spectral sum itself;
- ``record``: what the record model computes for these records: the IMU series (roll,
  pitch, the heave velocity) reduced by the data layer to the record table's tilt bands
  (:func:`flidar_uq.data.imu.tilt_band_statistics`, :func:`~flidar_uq.data.imu.tilt_spectrum_columns`),
  then :func:`flidar_uq.inference.record_motion.motion_gram` with the lidar and the record's
  wind direction and heading, at the truth's motion scale 1, lever arm 2 m and hull
  response (1 for the wave follower, 0 for the buoy that only rotates; the discus buoy's
  period-dependent response is not the record model's, so it has no ``record`` value);
- ``record_one_node``: the same with each band at its centroid period alone (one node, not
  the three of :func:`flidar_uq.physics.motion_spectrum.sub_band_nodes`);
- ``record_no_side``: the same without the bands' measured ``<sin psi>`` (the side of the
  wind a band's waves run on);
- ``heading_avg``: the record model with the heading unknown (averaged over headings)
  against the replay's rms over the eight headings, per (lidar, sea, hull, HWS).

Ratios are ``sqrt(mean(s_method^2) / mean(s_replay^2))`` over the records of a case. The
speeds of the record model's description (records/s: 8 bands, 3 nodes each) and of the
replay (10-min records/s) are measured in the same run.

``--study second-order``: sigma_Z of a DBS lidar on a wave follower: what the first-order harmonic sum leaves out.

The first-order harmonic sum of the along-wind error
(:func:`flidar_uq.physics.dbs_sigma_z.dbs_harmonic_sigma_z_ms`, ``cross_wind=False``)
against the LOS-level replay: how much of the difference is the HWS's nonlinearity in the
cross-wind error (in the record model to fourth order,
:func:`flidar_uq.physics.dbs_sigma_z.hws_error_moments`) and how much the rest. The
LOS-level replay (:func:`flidar_uq.physics.motion_spectrum.replay_sigma_z` with the DBS geometry, as
:func:`flidar_uq.physics.dbs_sigma_z.dbs_replay_sigma_z_ms`, each beam the mean over its
dwell) holds every order. This benchmark separates the two differences
on the seas of the replay study (a wave follower, head 2 m above the rotation
centre, 8 headings, 5 / 10 / 15 m/s, ``SECOND_ORDER_N_REC`` ten-minute records a case):

- ``linear_ratio``: first-order sum over replay with the motion scaled by 0.1 (the replay
  then linear in it): the first-order description itself, with the replay's sampling of a
  finite record;
- ``nonlinear_drift``: the same ratio at the true motion over the ratio at 0.1 of it: how
  much the replay's sigma_Z grows less (> 1) or more (< 1) than linearly;
- ``hws_factor``: the replay's sigma_Z over the std of its along-wind error ``a`` at the
  true motion, the HWS's own nonlinearity: ``Z = |U + a, b| - U``;
- ``hws_factor_4th``: its fourth-order value from the replay's ``a`` and cross-wind ``b``
  (:func:`flidar_uq.physics.dbs_sigma_z.hws_error_moments`:
  ``sqrt(1 + (s_b^4 / 2 - s_a^2 s_b^2 - 2 c_ab^2) / (U^2 s_a^2))``);
- ``along_drift``: the growth of ``s_a`` itself over linear (second-order along-wind terms:
  tilt times heave, tilt squared times U);
- ``mean_z_rel``: the replay's mean Z over U (the motion's bias of the mean HWS, in the TI's
  denominator), and ``mean_z_cross_rel``, its cross-wind part ``s_b^2 / (2 U^2)`` (the
  record model's).

``--study mechanisms``: what makes a DBS lidar's sigma_Z on a buoy: each mechanism's share on typical seas.

The harmonic sum of :func:`flidar_uq.physics.dbs_sigma_z.dbs_harmonic_sigma_z_ms` (within
5 % of LOS-level replay, the replay study) over the realised wave components of
typical seas (a 4-s wind sea; with a 9-s swell across or against the wind), for the
WindCube v2 (and v1, v2.1) with the head 2 m above the rotation centre, on a wave-following
hull and on a hull that only tilts, at 5, 10 and 15 m/s, averaged over the heading (the wind
direction relative to the beams uniform):

- ``geometry``: sigma_Z of the same cone with every beam of a cycle taken at once, as a
  share of the full sigma_Z (what the cone's geometry with the relative velocity gives
  alone; Desert, Knapp & Aubrun 2021 name it first);
- ``beam_timing``, ``tilt``, ``heave``, ``translation``, ``shear``: the share of sigma_Z^2 that goes
  when the mechanism is switched off, ``1 - sigma_Z,without^2 / sigma_Z^2`` (negative: the
  mechanism reduces sigma_Z; heave partly cancels the tilt's apparent vertical wind, so the
  shares need not add to one; ``shear``: the range gates that the tilt moves through a
  power-law profile of exponent 0.1, Yamaguchi and Ishihara 2016's offshore value);
- ``heading``: the std of sigma_Z over headings as a share of its rms (how much knowing the
  heading matters).

``--study output-sampling``: a DBS lidar's 10-min motion error, once a cycle or at every beam: its spread about the record model.

A pulsed DBS lidar can report its wind once a cycle (the four inclined beams and the
vertical one, 5 s for a WindCube v2) or at every beam, each new beam replacing the oldest
of its azimuth in the retrieval (about 1 s a value: the WindCube v2's 1-s real-time data,
and Yamaguchi & Ishihara 2016's estimates every second). The WindCube v2's geometry
(``every_beam_output``) takes the second, in the virtual campaign, the replay and the record
model (the mean over the windows' beam orders); a lidar that reports once a cycle, the
first. Sampled once a cycle, a swell near twice the cycle (10 s) is sampled
near its Nyquist period: each record's realised motion error then depends on the phase at
which the cycles meet the waves, which no 10-min statistic holds, so it strays from the
record model's expectation however well the record's tilt bands are known.

For swells of peak period 4-12 s (a heaving sea: JONSWAP gamma 6, 10 deg spread, across
the wind) on a wave-following hull with the head 2 m above its rotation centre, 8 m/s
blowing 30 deg off a beam, ``OUTPUT_N_REC`` ten-minute records a period:

- ``cycle``: the realised ``Z = HWS - U`` variance of the record, its motion replayed line
  of sight by line of sight (each beam the mean over its dwell, as the virtual campaign;
  :func:`flidar_uq.physics.dbs_sigma_z.dbs_replay_sigma_z_ms`), one value a cycle;
- ``beam``: the same lines of sight, one value at every beam from the latest beam of each
  azimuth (``every_beam=True``);
- ``model_cycle``, ``model_beam``: the record model's sigma_Z^2 of the record (its IMU
  series reduced to the tilt bands of the record table,
  :func:`flidar_uq.inference.record_motion.motion_gram` at the truth: motion scale 1, lever
  arm 2 m, hull response 1) for the lidar once a cycle and after every beam.

Per period: the mean and the relative spread (std / mean over the records) of
``cycle / model_cycle`` and ``beam / model_beam``; the once-a-cycle spread beyond the every-beam one
at 7-8 s, far from one and two cycles (``aliasing_spread``), against the record model's
(``predicted_spread``: the rms over the records of
:func:`flidar_uq.physics.dbs_sigma_z.cycle_sampling_rel_var` of their tilt bands, which
the record fit and the propagation add to the motion error's scatter). The spread is what a
10-min record's point estimate cannot know; it enters the corrected TI most where the
motion error is several times the turbulence.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np
import pandas as pd

from flidar_uq.data.imu import tilt_band_statistics, tilt_spectrum_columns
from flidar_uq.inference.record_motion import SAMPLING_COLUMN, gram_sigma_z_ms, motion_gram
from flidar_uq.physics import dbs_sigma_z as dbs
from flidar_uq.physics.lidar import get_lidar
from flidar_uq.physics.motion_spectrum import replay_sigma_z
from flidar_uq.physics.seastate import WaveSystem, hull_motion_series

OUT = Path(__file__).resolve().parent / "results"
DT_S = 0.05
RECORD_S = 600.0
DWELL_SAMPLES = 10
LEVER_M = 2.0
LIDARS = ("windcube_v2", "windcube_v1", "windcube_v2_1")
HWS = (5.0, 10.0, 15.0)
WIND_BODY_DEG = tuple(45.0 * k for k in range(8))  # the wind blows towards this body direction

# wave directions of travel relative to the wind's (0: downwind); rotated with the wind
SEAS = {
    "windsea": [WaveSystem(3.0, 4.0, 3.3, 0.0, 30.0)],
    "windsea_short": [WaveSystem(3.0, 3.0, 3.3, 0.0, 30.0)],
    "swell_across": [WaveSystem(2.4, 4.0, 3.3, 0.0, 30.0), WaveSystem(1.8, 9.0, 6.0, 90.0, 10.0)],
    "swell_against": [WaveSystem(2.4, 4.0, 3.3, 0.0, 30.0), WaveSystem(1.8, 9.0, 6.0, 180.0, 10.0)],
    "heaving_sea": [WaveSystem(2.0, 8.0, 6.0, 90.0, 10.0)],
}

# --study replay
REPLAY_N_REC = 36  # six hours a case: the replay's own sampling noise ~1.5 %
REPLAY_SEED = 20261204
HULL_NAMES = ("wave_follower", "discus_buoy", "rotation_only")
HULL_RESPONSE = {"wave_follower": 1.0, "rotation_only": 0.0}
METHODS = ("components", "record", "record_one_node", "record_no_side")
TOLERANCE = 0.05

# --study second-order
SECOND_ORDER_N_REC = 12
SECOND_ORDER_SEED = 20261205
SMALL = 0.1  # the motion scale at which the replay is linear in the motion
SECOND_ORDER_SEAS = ("windsea", "swell_across", "swell_against", "heaving_sea")

# --study mechanisms
MECHANISMS_SEED = 20261203
MECHANISMS_DURATION_S = 1800.0
N_HEADINGS = 24
MECHANISMS_HULLS = ("wave_follower", "rotation_only")
SHEAR_EXPONENT = 0.1
MECHANISMS_SEAS = {  # label: the sea of SEAS
    "windsea_4s": "windsea",
    "windsea+swell_across": "swell_across",
    "windsea+swell_against": "swell_against",
}
SWITCHED = ("beam_timing", "tilt", "heave", "translation", "shear")
COLUMNS = ("geometry", *SWITCHED, "heading")

# --study output-sampling
OUTPUT_N_REC = 96
OUTPUT_HWS_MS = 8.0
OUTPUT_WIND_BODY_DEG = 30.0  # the wind blows towards 30 deg from the body x axis (a beam at 0)
OUTPUT_LIDAR = "windcube_v2"
PERIODS_S = (4.0, 4.5, 5.0, 5.5, 6.0, 7.0, 8.0, 9.0, 9.5, 10.0, 10.5, 11.0, 12.0)
OUTPUT_SEED = 20261206
BASE_PERIODS_S = (7.0, 8.0)  # far from one and two cycles


def _rotated(systems, deg):
    return [
        WaveSystem(s.amplitude_deg, s.tp_s, s.gamma, s.direction_deg + deg, s.spread_deg)
        for s in systems
    ]


def record_table(roll_deg, pitch_deg, velocity_up_ms, wd_deg) -> pd.DataFrame:
    """The records' tilt bands as the data layer writes them from an IMU series (heading 0:
    the body axes are east and north), shape (n_records, n_samples) inputs."""
    spec = tilt_band_statistics(
        roll_deg, pitch_deg, 0.0, np.full(roll_deg.shape[0], wd_deg), 1.0 / DT_S,
        velocity_up_ms=velocity_up_ms,
    )  # fmt: skip
    rec = pd.DataFrame(tilt_spectrum_columns(spec))
    return rec.assign(wd_mean_deg=wd_deg, heading_mean_deg=0.0)


def _record_sigma_z(rec, hws, lidar, hull, *, heading=True, nodes=3, side=True):
    """sigma_Z (m/s) of the record model's description of ``rec`` (:func:`record_table`)."""
    rec = rec.assign(hws_mean_ms=hws)
    if not heading:
        rec = rec.assign(heading_mean_deg=np.nan)
    if not side:
        rec = rec.drop(columns=[c for c in rec if c.endswith("_sin_psi")])
    gram = motion_gram(rec, lidar=lidar, band_nodes=nodes)
    return gram_sigma_z_ms(
        gram, lever_arm_m=LEVER_M, hull_response=HULL_RESPONSE[hull], motion_scale=1.0
    )


def _replay_case_rows(rng, sea, hull, beta, lidar_rows):
    n10 = int(RECORD_S / DT_S)
    wd = float(dbs.wind_to_body_deg(beta))  # wind_to_body is its own inverse at yaw 0
    m = hull_motion_series(
        n10 * REPLAY_N_REC, DT_S, _rotated(SEAS[sea], beta), rng, hull, return_components=True
    )
    comp = m["components"]
    a_c = comp["amplitude_deg"].ravel()
    keep = a_c > 1e-4 * a_c.max()
    a_c, p_c, d_c = a_c[keep], comp["period_s"].ravel()[keep], comp["direction_deg"].ravel()[keep]
    trans = np.column_stack([m["surge_m"], m["sway_m"], m["heave_m"]])
    t = np.arange(n10) * DT_S
    roll, pitch = (m[k].reshape(REPLAY_N_REC, n10) for k in ("roll_deg", "pitch_deg"))
    rec = record_table(roll, pitch, np.gradient(m["heave_m"], DT_S).reshape(REPLAY_N_REC, n10), wd)
    for lidar in LIDARS:
        for hws in HWS:
            rep = np.array(
                [
                    dbs.dbs_replay_sigma_z_ms(
                        t,
                        roll[i],
                        pitch[i],
                        hws_ms=hws,
                        wd_deg=wd,
                        lever_arm_m=LEVER_M,
                        translation_m=trans[i * n10 : (i + 1) * n10],
                        lidar=lidar,
                        dwell_samples=DWELL_SAMPLES,
                    )  # fmt: skip
                    for i in range(REPLAY_N_REC)
                ]
            )
            row = dict(lidar=lidar, sea=sea, hull=hull, wind_body_deg=beta, hws_ms=hws)
            row["replay_ms"] = float(np.sqrt(np.mean(rep**2)))
            row["components"] = float(
                dbs.dbs_harmonic_sigma_z_ms(
                    a_c,
                    p_c,
                    d_c,
                    hws_ms=hws,
                    wind_body_deg=beta,
                    lever_arm_m=LEVER_M,
                    hull=hull,
                    lidar=lidar,
                    dwell_average=True,
                )  # fmt: skip
            )
            if hull in HULL_RESPONSE:
                for col, kw in (
                    ("record", {}),
                    ("record_one_node", {"nodes": 1}),
                    ("record_no_side", {"side": False}),
                    ("heading_unknown", {"heading": False}),
                ):
                    row[col] = float(
                        np.sqrt(np.mean(_record_sigma_z(rec, hws, lidar, hull, **kw) ** 2))
                    )
            lidar_rows.append(row)


def _replay_speeds(rng) -> tuple[float, float]:
    """Records/s of the record model's DBS description (8 bands x 3 nodes, heading known)
    and of the replay of a 10-min record."""
    n10 = int(RECORD_S / DT_S)
    m = hull_motion_series(n10 * 20, DT_S, SEAS["swell_across"], rng, "wave_follower")
    roll, pitch = (m[k].reshape(20, n10) for k in ("roll_deg", "pitch_deg"))
    rec = record_table(roll, pitch, np.gradient(m["heave_m"], DT_S).reshape(20, n10), 270.0)
    rec = pd.concat([rec] * 500, ignore_index=True).assign(hws_mean_ms=10.0)
    motion_gram(rec.iloc[:20], lidar="windcube_v2")
    t1 = time.perf_counter()
    motion_gram(rec, lidar="windcube_v2")
    gram_rate = len(rec) / (time.perf_counter() - t1)
    trans = np.column_stack([m["surge_m"], m["sway_m"], m["heave_m"]])[:n10]
    t = np.arange(n10) * DT_S
    t1 = time.perf_counter()
    for _ in range(3):
        dbs.dbs_replay_sigma_z_ms(
            t, roll[0], pitch[0], hws_ms=10.0, wd_deg=270.0, lever_arm_m=LEVER_M,
            translation_m=trans, dwell_samples=DWELL_SAMPLES,
        )  # fmt: skip
    return gram_rate, 3.0 / (time.perf_counter() - t1)


def study_replay(check: bool) -> int:
    """The replay study; returns the exit status (1: ``check`` and a ratio beyond 5 %)."""
    rng = np.random.default_rng(np.random.SeedSequence(REPLAY_SEED))
    rows: list[dict] = []
    t0 = time.perf_counter()
    for sea in SEAS:
        for hull in HULL_NAMES:
            for beta in WIND_BODY_DEG:
                _replay_case_rows(rng, sea, hull, beta, rows)
        print(f"{sea}: done ({time.perf_counter() - t0:.0f} s)", flush=True)
    df = pd.DataFrame(rows)
    summary = df.copy()
    for c in (*METHODS, "heading_unknown"):
        summary[c] = df[c] / df["replay_ms"]
    avg = (
        df[df.hull.isin(list(HULL_RESPONSE))]
        .groupby(["lidar", "sea", "hull", "hws_ms"])
        .apply(
            lambda g: pd.Series(
                {
                    "heading_avg": float(
                        np.sqrt(np.mean(g["heading_unknown"] ** 2) / np.mean(g["replay_ms"] ** 2))
                    ),
                    "replay_heading_cv": float(g["replay_ms"].std() / g["replay_ms"].mean()),
                }
            ),
            include_groups=False,
        )
        .reset_index()
    )
    gram_rate, replay_rate = _replay_speeds(rng)
    summary["record_per_s"] = gram_rate
    summary["replay_records_per_s"] = replay_rate
    OUT.mkdir(exist_ok=True)
    summary.drop(columns=["heading_unknown"]).to_csv(
        OUT / "dbs_sigma_z.csv", index=False, float_format="%.4f"
    )
    avg.to_csv(OUT / "dbs_sigma_z_heading_average.csv", index=False, float_format="%.4f")
    ok = True
    for col in METHODS:
        r = summary[col].dropna()
        within = np.mean(np.abs(r - 1.0) <= TOLERANCE)
        print(
            f"{col}: ratio to replay {r.min():.3f}-{r.max():.3f}, median {r.median():.3f}, "
            f"{100 * within:.1f} % of {r.size} cases within 5 %"
        )
        for lidar in LIDARS:
            g = summary[summary.lidar == lidar][col].dropna()
            print(f"  {lidar}: {g.min():.3f}-{g.max():.3f}")
        if col in ("components", "record"):
            ok &= bool(within == 1.0)
    worst = summary.assign(err=(summary["record"] - 1.0).abs()).nlargest(8, "err")
    print(worst[["lidar", "sea", "hull", "wind_body_deg", "hws_ms", "replay_ms", *METHODS]])
    h = avg["heading_avg"]
    print(
        f"heading unknown: ratio to the replay's rms over headings {h.min():.3f}-{h.max():.3f}; "
        f"the replay's spread over headings {100 * avg['replay_heading_cv'].median():.0f} % "
        "(median)"
    )
    print(
        f"record model's description {gram_rate:,.0f} records/s (8 bands x 3 nodes), replay "
        f"{replay_rate:.1f} records/s (10 min, {DT_S} s motion, {DWELL_SAMPLES} instants a "
        f"beam): x{gram_rate / replay_rate:,.0f}"
    )
    _replay_plot(summary)
    return 0 if ok or not check else 1


def _replay_plot(summary: pd.DataFrame) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(LIDARS), figsize=(16, 5), sharey=True)
    seas = list(SEAS)
    for ax, lidar in zip(axes, LIDARS, strict=True):
        g = summary[summary.lidar == lidar]
        for k, (hull, mk) in enumerate(zip(HULL_NAMES, "osd", strict=True)):
            gh = g[g.hull == hull]
            x = np.array([seas.index(s) for s in gh.sea]) + 0.2 * (k - 1)
            x = x + 0.02 * (gh.wind_body_deg.to_numpy() / 45.0 - 3.5)
            ax.scatter(x, gh["components"], marker=mk, s=12, alpha=0.5, label=f"{hull}: components")
            if hull in HULL_RESPONSE:
                ax.scatter(
                    x, gh["record"], marker=mk, s=16, facecolors="none", edgecolors="k",
                    linewidths=0.6, label=f"{hull}: record model",
                )  # fmt: skip
        ax.axhspan(1 - TOLERANCE, 1 + TOLERANCE, color="0.88", zorder=0, label="+-5 %")
        ax.set_xticks(range(len(seas)), seas, rotation=30, ha="right", fontsize=8)
        ax.set_title(lidar)
    axes[0].set_ylabel("sigma_Z / sigma_Z(LOS replay, dwell-averaged beams)")
    axes[0].legend(fontsize=7, ncol=2)
    fig.suptitle(
        "DBS sigma_Z: the spectral sum and the record model's tilt bands vs LOS-level replay "
        f"(8 headings, HWS 5-15 m/s, lever arm {LEVER_M:g} m)"
    )
    fig.tight_layout()
    fig.savefig(OUT / "dbs_sigma_z.png", dpi=110)


def _first_order(comp, scale, hws, beta, lidar) -> float:
    """The first-order along-wind sum (m/s) over the realised components."""
    return float(
        dbs.dbs_harmonic_sigma_z_ms(
            scale * comp[0],
            comp[1],
            comp[2],
            hws_ms=hws,
            wind_body_deg=beta,
            lever_arm_m=LEVER_M,
            hull="wave_follower",
            lidar=lidar,
            dwell_average=True,
            cross_wind=False,
        )  # fmt: skip
    )


def _pooled_replay(m, scale, hws, wd, beta, lidar) -> dict:
    """Pooled replay statistics of the records of ``m`` with the motion scaled."""
    n10 = int(RECORD_S / DT_S)
    t = np.arange(n10) * DT_S
    trans = scale * np.column_stack([m["surge_m"], m["sway_m"], m["heave_m"]])
    # heading 0: the body axes are east and north, the wind blows towards beta from east
    e_par = np.array([np.cos(np.deg2rad(beta)), np.sin(np.deg2rad(beta))])
    e_perp = np.array([-e_par[1], e_par[0]])
    z2, a2, b2, ab, mz = [], [], [], [], []
    for i in range(SECOND_ORDER_N_REC):
        sl = slice(i * n10, (i + 1) * n10)
        res = replay_sigma_z(
            t, scale * m["roll_deg"][sl], scale * m["pitch_deg"][sl], hws_ms=hws, wd_deg=wd,
            lever_arm_m=LEVER_M, translation_m=trans[sl], lidar=get_lidar(lidar),
            dwell_samples=DWELL_SAMPLES,
        )  # fmt: skip
        a = res.wind_ms @ e_par
        b = res.wind_ms @ e_perp
        a, b = a - a.mean(), b - b.mean()
        z2.append(res.sigma_z_ms**2)
        a2.append(np.mean(a * a))
        b2.append(np.mean(b * b))
        ab.append(np.mean(a * b))
        mz.append(res.mean_z_ms)
    return {
        k: float(np.mean(v))
        for k, v in zip(("z2", "a2", "b2", "ab", "mz"), (z2, a2, b2, ab, mz), strict=True)
    }


def _second_order_cases(rng) -> pd.DataFrame:
    rows = []
    for sea in SECOND_ORDER_SEAS:
        for beta in WIND_BODY_DEG:
            turned = _rotated(SEAS[sea], beta)
            m = hull_motion_series(
                int(RECORD_S / DT_S) * SECOND_ORDER_N_REC,
                DT_S,
                turned,
                rng,
                "wave_follower",
                return_components=True,
            )
            c = m["components"]
            amp = c["amplitude_deg"].ravel()
            keep = amp > 1e-4 * amp.max()
            comp = (amp[keep], c["period_s"].ravel()[keep], c["direction_deg"].ravel()[keep])
            wd = float(dbs.wind_to_body_deg(beta))  # its own inverse at yaw 0
            for lidar in LIDARS:
                for hws in HWS:
                    lo, hi = (_pooled_replay(m, s, hws, wd, beta, lidar) for s in (SMALL, 1.0))
                    f_lo, f_hi = (_first_order(comp, s, hws, beta, lidar) for s in (SMALL, 1.0))
                    sa2, sb2 = hi["a2"], hi["b2"]
                    var4, mean4 = dbs.hws_error_moments(sa2, sb2, hi["ab"], hws)
                    rows.append(
                        dict(
                            lidar=lidar,
                            sea=sea,
                            wind_body_deg=beta,
                            hws_ms=hws,
                            replay_ms=np.sqrt(hi["z2"]),
                            linear_ratio=f_lo / np.sqrt(lo["z2"]),
                            nonlinear_drift=(f_hi / np.sqrt(hi["z2"])) / (f_lo / np.sqrt(lo["z2"])),
                            hws_factor=np.sqrt(hi["z2"] / sa2),
                            hws_factor_4th=np.sqrt(var4 / sa2),
                            along_drift=np.sqrt(sa2 / lo["a2"]) * SMALL,
                            cross_over_u=np.sqrt(sb2) / hws,
                            mean_z_rel=hi["mz"] / hws,
                            mean_z_cross_rel=mean4 / hws,
                        )  # fmt: skip
                    )
        print(f"{sea}: done", flush=True)
    return pd.DataFrame(rows)


def _second_order_plot(df: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(15, 4.6))
    for sea, g in df.groupby("sea"):
        ax[0].scatter(g["cross_over_u"], g["nonlinear_drift"], s=12, label=sea)
        ax[1].scatter(g["hws_factor_4th"], g["hws_factor"], s=12, label=sea)
        ax[2].scatter(g["mean_z_cross_rel"] * 100, g["mean_z_rel"] * 100, s=12, label=sea)
    ax[0].axhline(1.0, color="k", lw=0.8)
    ax[0].set(xlabel="cross-wind error std / U (-)", ylabel="first-order / replay, true over 0.1 x motion",
              title="the replay's nonlinearity (> 1: the sum over)")  # fmt: skip
    lim = [min(df["hws_factor"].min(), df["hws_factor_4th"].min()), 1.005]
    ax[1].plot(lim, lim, "k", lw=0.8)
    ax[1].set(xlabel="4th-order HWS factor (from the replay's a, b)", ylabel="replay sigma_Z / std(a)",
              title="the HWS's own nonlinearity")  # fmt: skip
    hi = max(df["mean_z_cross_rel"].max(), df["mean_z_rel"].max()) * 100
    ax[2].plot([0, hi], [0, hi], "k", lw=0.8)
    ax[2].set(xlabel="cross-wind part s_b^2 / (2 U^2), %", ylabel="replay mean Z / U, %",
              title="the motion's bias of the mean HWS")  # fmt: skip
    ax[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def study_second_order() -> int:
    """The second-order study."""
    t0 = time.perf_counter()
    df = _second_order_cases(np.random.default_rng(np.random.SeedSequence(SECOND_ORDER_SEED)))
    OUT.mkdir(exist_ok=True)
    df.to_csv(OUT / "dbs_sigma_z_second_order.csv", index=False, float_format="%.5f")
    _second_order_plot(df, OUT / "dbs_sigma_z_second_order.png")
    cols = ["linear_ratio", "nonlinear_drift", "hws_factor", "hws_factor_4th", "along_drift",
            "mean_z_rel", "mean_z_cross_rel"]  # fmt: skip
    pd.set_option("display.width", 200)
    print(df.groupby(["lidar", "sea", "hws_ms"])[cols].mean().round(4).to_string())
    err4 = (df["hws_factor_4th"] - 1) / (df["hws_factor"] - 1)
    big = df["hws_factor"] < 0.995
    print(
        f"the 4th-order HWS factor's reduction over the replay's, where it is > 0.5 %: "
        f"median {err4[big].median():.2f} ({int(big.sum())} of {len(df)} cases)"
    )
    print(f"{len(df)} cases in {time.perf_counter() - t0:.0f} s")
    return 0


def _per_heading(a, p, d_wind, hws, lidar, hull, mechanisms):
    """sigma_Z over the headings (the sea turns with the wind), shape (N_HEADINGS,)."""
    beta = (np.arange(N_HEADINGS) + 0.5) * 360.0 / N_HEADINGS
    return np.array(
        [
            float(
                dbs.dbs_harmonic_sigma_z_ms(
                    a,
                    p,
                    d_wind + b,
                    hws_ms=hws,
                    wind_body_deg=b,
                    lever_arm_m=LEVER_M,
                    hull=hull,
                    lidar=lidar,
                    mechanisms=mechanisms,
                    shear_exponent=SHEAR_EXPONENT,
                )
            )
            for b in beta
        ]
    )


def study_mechanisms() -> int:
    """The mechanisms study."""
    rng = np.random.default_rng(np.random.SeedSequence(MECHANISMS_SEED))
    n = int(MECHANISMS_DURATION_S / DT_S)
    rows = []
    for sea, key in MECHANISMS_SEAS.items():
        for hull in MECHANISMS_HULLS:
            comp = hull_motion_series(n, DT_S, SEAS[key], rng, hull, return_components=True)[
                "components"
            ]
            a = comp["amplitude_deg"].ravel()
            keep = a > 1e-4 * a.max()
            a, p = a[keep], comp["period_s"].ravel()[keep]
            d = comp["direction_deg"].ravel()[keep]  # relative to the wind (downwind = 0)
            for lidar in LIDARS:
                for hws in HWS:
                    full = _per_heading(a, p, d, hws, lidar, hull, dbs.DBS_MECHANISMS)
                    rms = np.sqrt(np.mean(full**2))
                    row = dict(lidar=lidar, sea=sea, hull=hull, hws_ms=hws, sigma_z_ms=rms)
                    for mech in SWITCHED:
                        kept = tuple(m for m in dbs.DBS_MECHANISMS if m != mech)
                        s = _per_heading(a, p, d, hws, lidar, hull, kept)
                        row[mech] = 1.0 - np.mean(s**2) / rms**2
                    no_timing = tuple(m for m in dbs.DBS_MECHANISMS if m != "beam_timing")
                    s = _per_heading(a, p, d, hws, lidar, hull, no_timing)
                    row["geometry"] = np.sqrt(np.mean(s**2)) / rms
                    row["heading"] = np.std(full) / rms
                    rows.append(row)
    df = pd.DataFrame(rows)
    OUT.mkdir(exist_ok=True)
    df.to_csv(OUT / "dbs_mechanisms.csv", index=False, float_format="%.4f")
    pd.set_option("display.width", 200)
    print(df.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    g = df[(df.lidar == "windcube_v2") & (df.hws_ms == 10.0)]
    print(
        "\nWindCube v2, 10 m/s, heading-averaged (shares of sigma_Z^2; geometry, heading: of sigma_Z):"
    )
    print(
        g[["sea", "hull", "sigma_z_ms", *COLUMNS]].to_string(
            index=False, float_format=lambda v: f"{v:.2f}"
        )
    )
    _mechanisms_plot(df)
    return 0


def _mechanisms_plot(df: pd.DataFrame) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    g0 = df[(df.lidar == "windcube_v2") & (df.hws_ms == 10.0)]
    fig, axes = plt.subplots(1, len(MECHANISMS_HULLS), figsize=(13, 4.8), sharey=True)
    seas = list(MECHANISMS_SEAS)
    width = 0.8 / len(COLUMNS)
    for ax, hull in zip(axes, MECHANISMS_HULLS, strict=True):
        g = g0[g0.hull == hull].set_index("sea").loc[seas]
        for k, col in enumerate(COLUMNS):
            ax.bar(
                np.arange(len(seas)) + (k - 0.5 * (len(COLUMNS) - 1)) * width,
                g[col],
                width,
                label=col,
            )
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xticks(range(len(seas)), seas, fontsize=8)
        ax.set_title(f"{hull} (sigma_Z {', '.join(f'{v:.2f}' for v in g.sigma_z_ms)} m/s)")
    axes[0].set_ylabel("share")
    axes[0].legend(fontsize=8)
    fig.suptitle(
        "WindCube v2 on a buoy, 10 m/s, heading-averaged: share of sigma_Z^2 lost when a "
        "mechanism is off; geometry = simultaneous beams / full; heading = std / rms over headings",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(OUT / "dbs_mechanisms.png", dpi=110)


def _replay_both(t, roll, pitch, trans, wd_deg):
    """Realised ``Var Z`` (m/s)^2 of one record, one value a cycle and one at every beam."""
    return tuple(
        dbs.dbs_replay_sigma_z_ms(
            t, roll, pitch, hws_ms=OUTPUT_HWS_MS, wd_deg=wd_deg, lever_arm_m=LEVER_M,
            translation_m=trans, lidar=OUTPUT_LIDAR, dwell_samples=DWELL_SAMPLES, every_beam=beam,
        ) ** 2
        for beam in (False, True)
    )  # fmt: skip


def _model_var(roll, pitch, heave_velocity, wd_deg, g):
    """The record model's sigma_Z^2 (m/s)^2 of records (n_records, n_samples) at the truth
    for the lidar ``g``, and its relative variance of the realised Var Z from the
    retrieval once an output interval (four times the Gram's ``SAMPLING_COLUMN``)."""
    rec = record_table(roll, pitch, heave_velocity, wd_deg).assign(hws_mean_ms=OUTPUT_HWS_MS)
    gram = motion_gram(rec, lidar=g)
    var = gram_sigma_z_ms(gram, lever_arm_m=LEVER_M, hull_response=1.0, motion_scale=1.0) ** 2
    return var, 4.0 * gram[SAMPLING_COLUMN].to_numpy()


def study_output_sampling() -> int:
    """The output-sampling study."""
    t0 = time.perf_counter()
    g = get_lidar(OUTPUT_LIDAR)
    g_once = dataclasses.replace(g, every_beam_output=False)
    rng = np.random.default_rng(np.random.SeedSequence(OUTPUT_SEED))
    n10 = int(RECORD_S / DT_S)
    t = np.arange(n10) * DT_S
    wd = float(dbs.wind_to_body_deg(OUTPUT_WIND_BODY_DEG))
    rows = []
    for tp in PERIODS_S:
        sea = [WaveSystem(2.0, tp, 6.0, OUTPUT_WIND_BODY_DEG + 90.0, 10.0)]
        m = hull_motion_series(n10 * OUTPUT_N_REC, DT_S, sea, rng, "wave_follower")
        roll, pitch = (m[c].reshape(OUTPUT_N_REC, n10) for c in ("roll_deg", "pitch_deg"))
        trans = np.column_stack([m["surge_m"], m["sway_m"], m["heave_m"]]).reshape(
            OUTPUT_N_REC, n10, 3
        )
        w_up = np.gradient(m["heave_m"], DT_S).reshape(OUTPUT_N_REC, n10)
        model_cycle, rel_var = _model_var(roll, pitch, w_up, wd, g_once)
        model_beam = _model_var(roll, pitch, w_up, wd, g)[0]
        for i in range(OUTPUT_N_REC):
            cyc, beam = _replay_both(t, roll[i], pitch[i], trans[i], wd)
            rows.append(
                dict(
                    period_s=tp,
                    record=i,
                    model_cycle=model_cycle[i],
                    model_beam=model_beam[i],
                    rel_var=rel_var[i],
                    cycle=cyc,
                    beam=beam,
                )
            )
    df = pd.DataFrame(rows)
    df["cycle_ratio"] = df["cycle"] / df["model_cycle"]
    df["beam_ratio"] = df["beam"] / df["model_beam"]
    summary = df.groupby("period_s").agg(
        cycle_mean=("cycle_ratio", "mean"),
        cycle_spread=("cycle_ratio", lambda x: x.std() / x.mean()),
        beam_mean=("beam_ratio", "mean"),
        beam_spread=("beam_ratio", lambda x: x.std() / x.mean()),
        predicted_rel_var=("rel_var", "mean"),
    )
    summary["spread_ratio_cycle_to_beam"] = summary["cycle_spread"] / summary["beam_spread"]
    # the once-a-cycle spread beyond that of the periods that neither cycle aliases
    # (every beam at 7-8 s), against the record model's
    base = summary.loc[list(BASE_PERIODS_S), "beam_spread"].mean()
    summary["aliasing_spread"] = np.sqrt(np.maximum(summary["cycle_spread"] ** 2 - base**2, 0.0))
    summary["predicted_spread"] = np.sqrt(summary.pop("predicted_rel_var"))
    OUT.mkdir(exist_ok=True)
    summary.reset_index().to_csv(OUT / "dbs_output_sampling.csv", index=False, float_format="%.4f")
    print(summary.to_string(float_format=lambda v: f"{v:.3f}"))
    near = summary.loc[[9.5, 10.0, 10.5]]
    away = summary.loc[[6.0, 7.0, 8.0]]
    print(
        f"\nrealised / model Var Z, relative spread over {OUTPUT_N_REC} records a period: once a cycle "
        f"{near.cycle_spread.mean():.3f} at 9.5-10.5 s vs {away.cycle_spread.mean():.3f} at "
        f"6-8 s; at every beam {near.beam_spread.mean():.3f} vs {away.beam_spread.mean():.3f} "
        f"(near 10 s once a cycle / every beam: {near.cycle_spread.mean() / near.beam_spread.mean():.2f}x)"
    )
    one = summary.loc[[4.5, 5.0, 5.5]]
    print(
        "spread beyond the every-beam one at 7-8 s, measured vs the record model's "
        f"(cycle_sampling_rel_var): 9.5-10.5 s {near.aliasing_spread.mean():.3f} vs "
        f"{near.predicted_spread.mean():.3f}; 4.5-5.5 s {one.aliasing_spread.mean():.3f} vs "
        f"{one.predicted_spread.mean():.3f}; 7-8 s "
        f"{summary.loc[list(BASE_PERIODS_S), 'predicted_spread'].mean():.3f} predicted"
    )
    print(
        "mean realised / model Var Z over the periods (each against its own record model): "
        f"once a cycle {summary.cycle_mean.min():.3f}-{summary.cycle_mean.max():.3f}, after "
        f"every beam {summary.beam_mean.min():.3f}-{summary.beam_mean.max():.3f}"
    )
    print(f"wall {time.perf_counter() - t0:.0f} s")
    _output_sampling_plot(summary)
    return 0


def _output_sampling_plot(summary: pd.DataFrame) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    p = summary.index.to_numpy()
    for col, label in (("cycle", "once a cycle (5 s)"), ("beam", "at every beam (1 s)")):
        axes[0].plot(p, summary[f"{col}_spread"], "o-", label=label)
        axes[1].plot(p, summary[f"{col}_mean"], "o-", label=label)
    base = summary.loc[list(BASE_PERIODS_S), "beam_spread"].mean()
    axes[0].plot(
        p,
        np.sqrt(base**2 + summary["predicted_spread"] ** 2),
        "k--",
        label="record model once a cycle (its sampling term over the 7-8 s spread)",
    )
    for ax in axes:
        ax.axvline(2 * get_lidar(OUTPUT_LIDAR).scan_period_s, color="0.6", ls=":", lw=1)
        ax.axvline(get_lidar(OUTPUT_LIDAR).scan_period_s, color="0.6", ls=":", lw=1)
        ax.set_xlabel("swell peak period (s)")
        ax.legend(fontsize=8)
    axes[0].set_ylabel("std / mean of realised / model Var Z over records (-)")
    axes[1].set_ylabel("mean realised / model Var Z (-)")
    fig.suptitle(
        f"WindCube v2 on a wave follower, {OUTPUT_HWS_MS:g} m/s, heaving swell across the wind, "
        f"{OUTPUT_N_REC} ten-minute records a period (dotted: one and two cycles)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(OUT / "dbs_output_sampling.png", dpi=110)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--study",
        choices=("replay", "second-order", "mechanisms", "output-sampling"),
        default="replay",
    )
    ap.add_argument("--check", action="store_true", help="replay: exit 1 unless within 5 %%")
    args = ap.parse_args(argv)
    if args.study == "replay":
        return study_replay(args.check)
    studies = {
        "second-order": study_second_order,
        "mechanisms": study_mechanisms,
        "output-sampling": study_output_sampling,
    }
    return studies[args.study]()


if __name__ == "__main__":
    raise SystemExit(main())

"""Speed and accuracy of sigma_Z: seed 000's 24^3 grid vs the fast quadrature vs the surrogate.

Methods, each timed per evaluation in this run and compared with a converged reference
(fast kernel, 64 roll/pitch x 256 scan-phase points; its agreement with the scan-by-scan
simulation is a unit test):

(a) ``seed-loop-24``: seed 000 Sec. 2.3 written straightforwardly, one ``simulate_scan``
    call per (roll, pitch, scan) phase on the 24 x 24 x 24 grid;
(a') ``seed-vectorised-24``: the same grid, vectorised scan simulation (``method="direct"``);
(b) ``fourier-N``: the exact scan-phase reformulation with the trapezoid rule on N points per
    roll/pitch phase (4N scan phases), and ``default``: ``sigma_z()`` (adaptive, rtol 1e-6);
(c) ``surrogate``: ``get_surrogate().sigma_z_ms`` on 1e5 cases at once (time per case).

Writes benchmarks/results/sigma_z_speed_accuracy.csv and .png and prints the speed-up of
the default over (a).

Run: ``.venv/bin/python benchmarks/sigma_z_speed_accuracy.py``
"""

from __future__ import annotations

import csv
import itertools
import os
import time
from pathlib import Path

# Single-threaded BLAS: per-evaluation cost on one core (the pipeline runs many jobs side by
# side, and the seed loop is single-threaded too). Must be set before numpy is imported.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import matplotlib  # noqa: E402
import numpy as np  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from flidar_uq.physics.lidar import ZEPHIR300, wind_vector_ms  # noqa: E402
from flidar_uq.physics.motion import harmonic_motion  # noqa: E402
from flidar_uq.physics.simulator import sigma_z, sigma_z_grid, simulate_scan  # noqa: E402
from flidar_uq.physics.surrogate import get_surrogate  # noqa: E402

OUT = Path(__file__).resolve().parent / "results"
CASES = [  # (hws_ms, amplitude_deg, period_s): typical, strong, extreme near the scan period
    (8.0, 3.0, 4.0),
    (8.0, 10.0, 2.0),
    (8.0, 25.0, 1.2),
]
SEED_N = 24


def _timeit(fn, min_time_s=0.3, max_reps=2000):
    """Median wall time of ``fn()`` over repeats lasting about ``min_time_s``."""
    t0 = time.perf_counter()
    val = fn()
    first = time.perf_counter() - t0
    reps = int(min(max_reps, max(1, min_time_s / max(first, 1e-9))))
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)) if times else first, val


def seed_loop(hws, amp, per, n=SEED_N):
    """Seed 000's 24^3 procedure, one scan simulation per phase triple (Eqs. 4, 9, 12, 14)."""
    phases = 2 * np.pi * np.arange(n) / n
    wind = wind_vector_ms(hws, 0.0)
    z = np.empty((n, n, n))
    for i, pr in enumerate(phases):
        for j, pp in enumerate(phases):
            motion = harmonic_motion(amp, per, pr, pp)
            for k, ps in enumerate(phases):
                z[i, j, k] = simulate_scan(
                    ZEPHIR300, motion, wind, 0.0, ps, sign_ambiguity=False
                ).z_ms
    g1 = z.mean(axis=2)  # Eq. (9): average over the scan phase
    g2 = (z**2).mean(axis=2)
    mean = g1.mean(axis=1).mean()  # Eqs. (12), (14)
    var = g2.mean(axis=1).mean() - mean**2  # Eq. (4)
    return float(np.sqrt(var)), float(mean)


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    rows = []
    sur_build_t0 = time.perf_counter()
    sur = get_surrogate(ZEPHIR300)
    sur_build_s = time.perf_counter() - sur_build_t0
    speedups = []
    for hws, amp, per in CASES:
        label = f"{hws:g} m/s, {amp:g} deg, {per:g} s"
        ref_s, ref_m = sigma_z_grid(hws, amp, per, nphase=64, nphase_scan=256)

        def add(method, n, t, val, label=label, ref_s=ref_s, ref_m=ref_m):
            rows.append(
                dict(
                    case=label,
                    method=method,
                    nphase=n,
                    time_per_eval_s=t,
                    sigma_z_ms=val[0],
                    mean_z_ms=val[1],
                    rel_error_sigma=abs(val[0] - ref_s) / ref_s,
                    error_mean_over_sigma=abs(val[1] - ref_m) / ref_s,
                )
            )

        t0 = time.perf_counter()
        val = seed_loop(hws, amp, per)
        t_seed = time.perf_counter() - t0
        add("seed-loop-24", SEED_N, t_seed, val)
        t, val = _timeit(
            lambda h=hws, a=amp, p=per: sigma_z_grid(
                h, a, p, nphase=SEED_N, nphase_scan=SEED_N, method="direct"
            ),
            min_time_s=1.0,
            max_reps=3,
        )
        add("seed-vectorised-24", SEED_N, t, val)
        t_vec = t
        for n in (2, 3, 4, 6, 8, 12, 16, 24, 32):
            t, val = _timeit(lambda h=hws, a=amp, p=per, n=n: sigma_z_grid(h, a, p, nphase=n))
            add(f"fourier-{n}", n, t, val)
        t, res = _timeit(lambda h=hws, a=amp, p=per: sigma_z(h, a, p))
        add("default", res.n_phase, t, (res.sigma_z_ms, res.mean_z_ms))
        t_default = t
        default_row = rows[-1]
        rng = np.random.default_rng(np.random.SeedSequence(2018))
        m = 100_000
        hv = np.full(m, hws)
        av = np.full(m, amp)
        pv = np.full(m, per)
        hv[1:] = rng.uniform(1, 20, m - 1)
        av[1:] = rng.uniform(0, 25, m - 1)
        pv[1:] = np.exp(rng.uniform(0, np.log(20), m - 1))
        t, s_all = _timeit(
            lambda h=hv, a=av, p=pv: sur.sigma_z_ms(h, a, p), min_time_s=1.0, max_reps=20
        )
        # accuracy of this case at the reference's direction (wd = 0)
        s0 = float(sur.sigma_z_ms(hws, amp, per, 0.0))
        m0 = float(sur.mean_z_ms(hws, amp, per, 0.0))
        add("surrogate", 0, t / m, (s0, m0))
        t_wd, _ = _timeit(
            lambda h=hv, a=av, p=pv: sur.sigma_z_ms(h, a, p, 30.0), min_time_s=1.0, max_reps=20
        )
        add("surrogate-wd", 0, t_wd / m, (s0, m0))
        speedups.append(
            (label, t_seed, t_vec, t_default, t_seed / t_default, res.n_phase, default_row)
        )

    path_csv = OUT / "sigma_z_speed_accuracy.csv"
    with path_csv.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})

    fig, axes = plt.subplots(1, len(CASES), figsize=(5 * len(CASES), 4.2), sharey=True)
    floor = 1e-17
    for ax, (hws, amp, per) in zip(axes, CASES, strict=True):
        label = f"{hws:g} m/s, {amp:g} deg, {per:g} s"
        sub = [r for r in rows if r["case"] == label]
        four = [r for r in sub if r["method"].startswith("fourier")]
        ax.loglog(
            [r["time_per_eval_s"] for r in four],
            [max(r["rel_error_sigma"], floor) for r in four],
            "o-",
            label="fast quadrature (N per phase)",
        )
        for r in four:
            ax.annotate(
                str(r["nphase"]),
                (r["time_per_eval_s"], max(r["rel_error_sigma"], floor)),
                fontsize=7,
            )
        style = {
            "seed-loop-24": ("s", "C3", "seed 24^3, scan loop"),
            "seed-vectorised-24": ("D", "C1", "seed 24^3, vectorised"),
            "default": ("*", "C2", "sigma_z() default"),
            "surrogate": ("^", "C4", "surrogate, direction-averaged (per case, 1e5 batch)"),
            "surrogate-wd": ("v", "C5", "surrogate with wd_deg (per case, 1e5 batch)"),
        }
        for r in sub:
            if r["method"] in style:
                mk, col, lab = style[r["method"]]
                ax.loglog(
                    r["time_per_eval_s"],
                    max(r["rel_error_sigma"], floor),
                    mk,
                    color=col,
                    ms=9,
                    label=lab,
                )
        ax.axhline(1e-6, color="grey", lw=0.8, ls="--")
        ax.set_title(label)
        ax.set_xlabel("time per evaluation (s)")
    axes[0].set_ylabel("relative error of sigma_Z")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    path_png = OUT / "sigma_z_speed_accuracy.png"
    fig.savefig(path_png, dpi=110)

    print(f"surrogate build time: {sur_build_s:.2f} s")
    print(f"{'case':28s} {'method':20s} {'N':>4s} {'time/eval (s)':>14s} {'rel.err sigma':>14s}")
    for r in rows:
        print(
            f"{r['case']:28s} {r['method']:20s} {r['nphase']:4d} {r['time_per_eval_s']:14.3e} "
            f"{r['rel_error_sigma']:14.2e}"
        )
    print()
    for label, t_seed, t_vec, t_def, ratio, n, row in speedups:
        print(
            f"[{label}] seed 24^3 loop {t_seed:.3f} s | vectorised 24^3 {t_vec * 1e3:.1f} ms | "
            f"default sigma_z {t_def * 1e3:.3f} ms (N={n}, rel.err {row['rel_error_sigma']:.1e}) "
            f"| speed-up {ratio:,.0f}x over the loop, {t_vec / t_def:,.0f}x over the vectorised "
            "grid (issue 13 target 1000x)"
        )
    sur_rows = [r for r in rows if r["method"] == "surrogate"]
    wd_rows = [r for r in rows if r["method"] == "surrogate-wd"]
    print(
        f"surrogate: {1 / sur_rows[0]['time_per_eval_s']:,.0f} cases/s direction-averaged, "
        f"{1 / wd_rows[0]['time_per_eval_s']:,.0f} cases/s with wd_deg (1e5-case batches)"
    )
    # surrogate accuracy over the whole table range (random points plus the corners)
    rng = np.random.default_rng(np.random.SeedSequence(300))
    amp = np.concatenate([rng.uniform(0, 25, 300), [25, 25, 0.01, 0.01]])
    per = np.concatenate([np.exp(rng.uniform(0, np.log(20), 300)), [1, 20, 1, 20]])
    wd = rng.uniform(0, 360, amp.size)
    ref = np.array(
        [sigma_z_grid(1.0, a, p, w, nphase=16) for a, p, w in zip(amp, per, wd, strict=True)]
    )
    err_s = np.abs(sur.sigma_z_ms(1.0, amp, per, wd) / ref[:, 0] - 1)
    err_m = np.abs(sur.mean_z_ms(1.0, amp, per, wd) - ref[:, 1]) / ref[:, 0]
    i = int(np.argmax(err_s))
    print(
        f"surrogate over amplitude 0-25 deg x period 1-20 s x direction 0-360 deg ({amp.size} "
        f"points): max rel. error of sigma_Z {err_s.max():.1e} (at {amp[i]:.2f} deg, "
        f"{per[i]:.2f} s, {wd[i]:.0f} deg), median {np.median(err_s):.1e}; "
        f"max |error of E(Z)| / sigma_Z {err_m.max():.1e}"
    )
    # direction-averaged default against the RMS over 16 directions (0-180 deg)
    wds = np.arange(0.0, 180.0, 11.25)
    sub = slice(0, 40)
    ref_avg = np.array(
        [
            np.sqrt(np.mean([sigma_z_grid(1.0, a, p, w, nphase=16)[0] ** 2 for w in wds]))
            for a, p in zip(amp[sub], per[sub], strict=True)
        ]
    )
    err_avg = np.abs(sur.sigma_z_ms(1.0, amp[sub], per[sub]) / ref_avg - 1)
    print(
        f"direction-averaged surrogate ({ref_avg.size} points): max rel. error {err_avg.max():.1e}"
    )
    print(f"wrote {path_csv} and {path_png}")
    two_period_rule(sur)


def two_period_rule(sur) -> None:
    """Variance-addition rule for two-period motion against the direct 5-phase integral."""
    rows = []
    grid = itertools.product(
        (2.0, 5.0, 10.0, 20.0, 25.0), (1.0, 1.5, 3.0, 6.0), (8.0, 15.0, 20.0), (0.2, 0.5, 0.8)
    )
    for a, t1, t2, w in grid:
        ref = sigma_z_grid(
            1.0, a * np.sqrt(w), t1, 0.0, nphase=8, amplitude2_deg=a * np.sqrt(1 - w), period2_s=t2
        )[0]
        rule = float(sur.sigma_z_two_period_ms(1.0, a, t1, t2, w, 0.0))
        rows.append(
            dict(
                amplitude_deg=a,
                period1_s=t1,
                period2_s=t2,
                weight1=w,
                direct=ref,
                rule=rule,
                rel_error=rule / ref - 1,
            )
        )
    path = OUT / "sigma_z_two_period_rule.csv"
    with path.open("w", newline="") as fh:
        wr = csv.DictWriter(fh, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows({k: f"{v:.6g}" for k, v in r.items()} for r in rows)
    err = np.array([r["rel_error"] for r in rows])
    i = int(np.argmax(np.abs(err)))
    print(
        f"two-period rule (variance addition) vs direct 5-phase integral, {len(rows)} cases: worst "
        f"{err[i]:+.2%} at A={rows[i]['amplitude_deg']:g} deg, T1={rows[i]['period1_s']:g} s, "
        f"T2={rows[i]['period2_s']:g} s, w={rows[i]['weight1']:g}"
    )
    for a in (2.0, 5.0, 10.0, 20.0, 25.0):
        sub = np.abs([r["rel_error"] for r in rows if r["amplitude_deg"] == a])
        print(
            f"  total amplitude {a:4.0f} deg: worst |error| {sub.max():.2%}, median {np.median(sub):.2%}"
        )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()

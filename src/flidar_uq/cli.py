"""``flidar-uq`` command line.

Subcommands are registered in :data:`SUBCOMMANDS` (name -> ``(add_arguments, run, help)``);
other modules' commands are added there. ``sigma-z`` and ``generate-campaign`` print their
result on stdout as one JSON object; ``validate`` and ``convert`` print a short summary for
people, and the JSON object with ``--json``; ``run`` prints one line per pipeline step and a
summary. Bad input gives exactly one line on stderr naming the argument, config
key or file, row and column, never a traceback, and an exit status per class
(:data:`flidar_uq.workflow.inputs.EXIT_CODES`): 0 ok, 2 usage error (argument or config
key), 3 bad data (file missing, unreadable, malformed, wrong units), 1 internal error.

Example::

    flidar-uq sigma-z --hws-ms 8 --amplitude-deg 3 --period-s 4
    flidar-uq sigma-z --hws-ms 8 --amplitude-deg 3 --period-s 4 --period2-s 12 --weight1 0.6
    flidar-uq validate my_campaign.csv
    flidar-uq validate --config my_config.yaml --json
    flidar-uq run --cores 2 --configfile my_config.yaml
    flidar-uq generate-campaign --scenario tiny --seed 1 --output tiny.csv
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable, Sequence

from flidar_uq.workflow.inputs import (
    EXIT_CODES,
    EXIT_DATA,
    EXIT_INTERNAL,
    EXIT_OK,
    EXIT_USAGE,
    exit_status,
)

__all__ = ["main", "build_parser", "SUBCOMMANDS", "CliError"]


class CliError(Exception):
    """Bad command-line input; its message is printed as one line on stderr."""


class _OneLineParser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line on stderr (no usage block, no traceback)."""

    def error(self, message: str):  # noqa: D102 - argparse API
        raise CliError(f"{self.prog}: error: {message}")


# ---- argument types (argparse turns ArgumentTypeError into "argument --x: <message>") ----


def _number(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(x):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return x


def _positive(text: str) -> float:
    x = _number(text)
    if x <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return x


def _amplitude(text: str) -> float:
    x = _number(text)
    if not 0.0 <= x <= 45.0:
        raise argparse.ArgumentTypeError(f"must be in [0, 45] deg, got {text!r}")
    return x


def _fraction(text: str) -> float:
    x = _number(text)
    if not 0.0 <= x <= 1.0:
        raise argparse.ArgumentTypeError(f"must be in [0, 1], got {text!r}")
    return x


def _lidar(text: str):
    from flidar_uq.physics.lidar import get_lidar

    try:
        return get_lidar(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


# ---- sigma-z -----------------------------------------------------------------------------


def _add_sigma_z(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--hws-ms", type=_positive, required=True, help="horizontal wind speed, m/s (> 0)"
    )
    p.add_argument(
        "--amplitude-deg",
        type=_amplitude,
        required=True,
        help="roll and pitch amplitude A, deg in [0, 45]; with --period2-s the total amplitude",
    )
    p.add_argument(
        "--period-s", type=_positive, required=True, help="roll and pitch period, s (> 0)"
    )
    p.add_argument(
        "--wd-deg", type=_number, default=0.0, help="wind direction (from), deg; default 0"
    )
    p.add_argument(
        "--lidar", type=_lidar, default="zephir300", help="lidar name; default zephir300"
    )
    p.add_argument(
        "--period2-s",
        type=_positive,
        default=None,
        help="second motion period, s: two-period motion with A1 = A sqrt(w), A2 = A sqrt(1 - w)",
    )
    p.add_argument(
        "--weight1",
        type=_fraction,
        default=None,
        help="variance share w of the first period, in [0, 1]",
    )
    p.add_argument(
        "--lever-arm-m",
        type=_number,
        default=0.0,
        help="lidar head height above the rotation centre, m",
    )
    p.add_argument("--rtol", type=_positive, default=1e-6, help="relative tolerance; default 1e-6")
    p.add_argument(
        "--surrogate",
        action="store_true",
        help="use the tabulated surrogate (amplitude <= 25 deg, period 1-20 s, no lever arm)",
    )


def _run_sigma_z(args: argparse.Namespace) -> dict:
    from flidar_uq.physics.lidar import get_lidar
    from flidar_uq.physics.simulator import sigma_z

    lidar = get_lidar(args.lidar)
    if (args.period2_s is None) != (args.weight1 is None):
        missing = "--weight1" if args.weight1 is None else "--period2-s"
        raise CliError(
            f"flidar-uq sigma-z: error: argument {missing}: required with two-period motion"
        )
    two = args.period2_s is not None
    out = {
        "hws_ms": args.hws_ms,
        "amplitude_deg": args.amplitude_deg,
        "period_s": args.period_s,
        "wd_deg": args.wd_deg,
        "lidar": lidar.name,
        "period2_s": args.period2_s,
        "weight1": args.weight1,
        "lever_arm_m": args.lever_arm_m,
    }
    if args.surrogate:
        from flidar_uq.physics.surrogate import AMPLITUDE_RANGE_DEG, PERIOD_RANGE_S, get_surrogate

        if args.lever_arm_m != 0.0:
            raise CliError(
                "flidar-uq sigma-z: error: argument --surrogate: no lever arm in the surrogate"
            )
        if args.amplitude_deg > AMPLITUDE_RANGE_DEG[1]:
            raise CliError(
                f"flidar-uq sigma-z: error: argument --amplitude-deg: the surrogate covers "
                f"0-{AMPLITUDE_RANGE_DEG[1]:g} deg, got {args.amplitude_deg:g}"
            )
        for name, val in (("--period-s", args.period_s), ("--period2-s", args.period2_s)):
            if val is not None and not PERIOD_RANGE_S[0] <= val <= PERIOD_RANGE_S[1]:
                raise CliError(
                    f"flidar-uq sigma-z: error: argument {name}: the surrogate covers "
                    f"{PERIOD_RANGE_S[0]:g}-{PERIOD_RANGE_S[1]:g} s, got {val:g}"
                )
        s = get_surrogate(lidar)
        if two:
            sig = s.sigma_z_two_period_ms(
                args.hws_ms,
                args.amplitude_deg,
                args.period_s,
                args.period2_s,
                args.weight1,
                args.wd_deg,
            )
            out.update(sigma_z_ms=float(sig), mean_z_ms=None, method="surrogate-two-period")
        else:
            out.update(
                sigma_z_ms=float(
                    s.sigma_z_ms(args.hws_ms, args.amplitude_deg, args.period_s, args.wd_deg)
                ),
                mean_z_ms=float(
                    s.mean_z_ms(args.hws_ms, args.amplitude_deg, args.period_s, args.wd_deg)
                ),
                method="surrogate",
            )
        return out
    kw = {}
    amp = args.amplitude_deg
    if two:
        amp = args.amplitude_deg * math.sqrt(args.weight1)
        kw = dict(
            amplitude2_deg=args.amplitude_deg * math.sqrt(1.0 - args.weight1),
            period2_s=args.period2_s,
        )
    res = sigma_z(
        args.hws_ms,
        amp,
        args.period_s,
        args.wd_deg,
        lidar,
        lever_arm_m=args.lever_arm_m,
        rtol=args.rtol,
        **kw,
    )
    out.update(
        sigma_z_ms=res.sigma_z_ms,
        mean_z_ms=res.mean_z_ms,
        n_phase=res.n_phase,
        error_estimate_ms=res.error_estimate_ms,
        converged=res.converged,
        method=res.method,
    )
    return out


# ---- validate ------------------------------------------------------------------------------


def _add_validate(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "path",
        nargs="?",
        default=None,
        help="record table (.csv, .csv.gz, .parquet), docs/data-format.md; default: the "
        "config's campaign.records",
    )
    p.add_argument(
        "--config",
        default=None,
        help="pipeline config (YAML, as for snakemake --configfile): checked like the "
        "pipeline does; its campaign.columns, heights, allow_small_angles and qc apply",
    )
    p.add_argument(
        "--allow-small-angles",
        action="store_true",
        help="do not reject motion amplitudes that look like radians (a calm site)",
    )
    p.add_argument("--imu-series", default=None, help="also check a raw IMU series file")
    p.add_argument("--los-series", default=None, help="also check a LOS file (needs --imu-series)")
    _add_json(p, _validate_summary)


def _run_validate(args: argparse.Namespace) -> dict:
    from flidar_uq.data.formats import read_los_file
    from flidar_uq.data.io import los_imu_match, read_imu_series
    from flidar_uq.workflow.inputs import (
        check_config,
        inspect_records,
        load_config_file,
        read_campaign_records,
    )

    config = None
    if args.config is not None:
        config = check_config(load_config_file(args.config))
    campaign = config["campaign"] if config else {}
    path = args.path or campaign.get("records")
    if not path:
        raise CliError(
            "flidar-uq validate: error: argument path: give the record table, or --config "
            "with campaign.records"
        )
    if args.los_series and not args.imu_series:
        raise CliError(
            "flidar-uq validate: error: argument --los-series: a LOS file needs its IMU "
            "series (--imu-series)"
        )
    small = bool(args.allow_small_angles or campaign.get("allow_small_angles", False))
    records = read_campaign_records(path, campaign, allow_small_angles=small)
    report = inspect_records(
        records,
        source=str(path),
        qc_params=config["qc"] if config else None,
        heights=campaign.get("heights"),
        columns=campaign.get("columns"),
    )
    out = {"path": str(path), "valid": True, **report}
    if args.imu_series:
        imu = read_imu_series(args.imu_series, allow_small_angles=small)
        out["imu_series"] = {"path": args.imu_series, "n_samples": len(imu)}
        if args.los_series:
            los, facts = read_los_file(args.los_series, utc_offset_h=campaign.get("utc_offset_h"))
            ok = los_imu_match(los, imu, los_source=args.los_series, imu_source=args.imu_series)
            out["los_series"] = {
                "path": args.los_series,
                "format": facts["format"],
                "n_measurements": len(los),
                "share_with_imu": round(float(ok.mean()), 4) if len(ok) else 0.0,
            }
    out.update(_source_facts(path, campaign))
    if args.json:
        _validate_stderr(out)
    return out


def _validate_stderr(out: dict) -> None:
    """With ``--json``: the header facts, the joins and the warnings on stderr."""
    if out["format"] != "table":
        facts = ", ".join(f"{k}={v}" for k, v in out["header_facts"].items())
        print(f"flidar-uq validate: {out['format']}: {facts}", file=sys.stderr)
    for j in out["join"]:
        print(
            f"flidar-uq validate: join {j['role']} {j['path']}: {j['intervals']} intervals, "
            f"{j['matched']} matched, {j['unmatched_lidar']} lidar intervals unmatched, "
            f"{j['unmatched_file']} of the file unmatched",
            file=sys.stderr,
        )
    for line in out["blocking"]:
        print(f"flidar-uq validate: warning: {line} (the pipeline stops on this)", file=sys.stderr)
    for line in out["warnings"]:
        print(f"flidar-uq validate: warning: {line}", file=sys.stderr)


def _add_json(p: argparse.ArgumentParser, summary: Callable[[dict], list[str]]) -> None:
    p.add_argument(
        "--json", action="store_true", help="print the result as one JSON object (for machines)"
    )
    p.set_defaults(_summary=summary)


def _format_words(fmt: str, facts: dict) -> str:
    """The detected format and where an IEA Task 43 file's metadata came from."""
    meta = facts.get("metadata")
    if meta == "header":
        return f"{fmt} (metadata: the file's JSON header)"
    return f"{fmt} (metadata: {meta}, beside the file)" if meta else fmt


def _records_lines(report: dict) -> list[str]:
    """Records, heights, period, the QC preview and the warnings of an inspection."""
    span = report.get("time_span") or {}
    qc = report.get("qc_preview") or {}
    flags = ", ".join(f"{k} {v}" for k, v in (qc.get("by_filter") or {}).items() if v)
    out = [
        f"records: {report['n_records']} at heights "
        + ", ".join(f"{h:g}" for h in report.get("heights_m", []))
        + " m",
    ]
    if span.get("start"):
        out.append(f"period: {span['start']} to {span['end']} ({span['days']:g} days)")
    if qc:
        out.append(
            f"QC would keep {qc['n_kept']} of {report['n_records']}"
            + (f"; flags: {flags}" if flags else "; no flags")
        )
    out += [f"stops the pipeline: {w}" for w in report.get("blocking", [])]
    out += [f"warning: {w}" for w in report.get("warnings", [])]
    return out


def _join_lines(join: list[dict]) -> list[str]:
    """One line per joined file: its matched intervals, or for a file coarser than the
    10-min records its cadence and the records that took one of its bursts."""
    from flidar_uq.data.formats.common import INTERVAL_MIN

    out = []
    for j in join:
        head = f"join {j['role']} {j['path']}: "
        if j["interval_min"] > INTERVAL_MIN:
            out.append(
                head + f"every {j['interval_min']:g} min; {j['matched']} intervals took one of "
                f"its {j['intervals']} bursts, {j['unmatched_lidar']} none"
            )
        else:
            out.append(head + f"{j['matched']} of {j['intervals']} intervals matched")
    return out


def _validate_summary(out: dict) -> list[str]:
    """``flidar-uq validate``'s summary for people."""
    lines = [
        f"{out['path']}: valid",
        "format: " + _format_words(out["format"], out["header_facts"]),
    ]
    lines += _records_lines(out)
    lines += _join_lines(out["join"])
    if "imu_series" in out:
        lines.append(f"IMU series: {out['imu_series']['n_samples']} samples")
    if "los_series" in out:
        los = out["los_series"]
        lines.append(
            f"LOS series ({los['format']}): {los['n_measurements']} measurements, "
            f"{los['share_with_imu']:.0%} with IMU samples"
        )
    return lines


def _source_facts(path, campaign) -> dict:
    """The detected format of a file, what its header states and the join of a campaign in
    several files (``format``, ``header_facts``, ``notes``, ``join``)."""
    from flidar_uq.data.formats import detect_format
    from flidar_uq.data.formats.join import read_campaign

    fmt = campaign.get("format") or "auto"
    if fmt == "auto":
        fmt = "table" if campaign.get("columns") else detect_format(path)
    parts = any((campaign.get(f"{r}_file") or {}).get("path") for r in ("motion", "reference"))
    if fmt == "table" and not parts:
        return {"format": "table", "header_facts": {}, "notes": [], "join": []}
    _, join, facts, notes = read_campaign(
        path, {**campaign, "format": fmt}, require_motion=False, allow_small_angles=True
    )
    return {
        "format": fmt,
        "header_facts": facts,
        "notes": notes,
        "join": join.to_dict("records"),
    }


# ---- convert -------------------------------------------------------------------------------


def _add_convert(p: argparse.ArgumentParser) -> None:
    p.add_argument("path", help="a record table or an instrument file (.sta, ZephIR CSV, IEA 43)")
    p.add_argument("--output", required=True, help="the record table to write (.csv, .parquet)")
    p.add_argument(
        "--format",
        default="auto",
        choices=["auto", "table", "windcube_sta", "zephir_csv", "iea43"],
        help="the input's format; default auto (from its first line)",
    )
    p.add_argument("--utc-offset-h", type=_number, default=None, help="stamps' offset from UTC, h")
    p.add_argument("--timestamp-at", choices=["start", "end"], default=None, help="stamp position")
    p.add_argument(
        "--heading-convention", choices=["ccw", "compass"], default="ccw", help="heading column"
    )
    p.add_argument(
        "--extra-columns", choices=["keep", "ignore", "error"], default="keep", help="other columns"
    )
    p.add_argument(
        "--motion-file",
        default=None,
        help="the buoy's logger or wave file (CSV or Parquet, UTC stamps at the start of its "
        "intervals) joined onto the records; a coarser cadence is joined burst by burst",
    )
    p.add_argument(
        "--motion-column",
        action="append",
        default=[],
        type=_column_pair,
        metavar="NAME=COLUMN",
        help="column map of --motion-file, one per column: HM0=wave_hs_m (repeat)",
    )
    _add_json(p, _convert_summary)


def _column_pair(text: str) -> tuple[str, str]:
    """``NAME=COLUMN`` of a column map given on the command line."""
    name, sep, column = text.partition("=")
    if not sep or not name.strip() or not column.strip():
        raise argparse.ArgumentTypeError(f"expected NAME=COLUMN, got {text!r}")
    return name.strip(), column.strip()


def _run_convert(args: argparse.Namespace) -> dict:
    from flidar_uq.data.formats import complete_motion, read_any
    from flidar_uq.data.formats.join import join_records, join_report, read_part
    from flidar_uq.data.io import write_records
    from flidar_uq.workflow.inputs import inspect_records

    conv = {
        "format": args.format,
        "utc_offset_h": args.utc_offset_h,
        "timestamp_at": args.timestamp_at,
        "heading_convention": args.heading_convention,
    }
    got = read_any(args.path, conv, extra_columns=args.extra_columns)
    records, join = got.records, []
    if args.motion_file:
        part = {"path": args.motion_file, "columns": dict(args.motion_column)}
        motion = read_part(part, extra_columns=args.extra_columns)
        records, rows = join_records(records, {"motion": motion})
        paths = {"lidar": str(args.path), "motion": str(args.motion_file)}
        join = join_report(rows, paths).to_dict("records")
    records, notes = complete_motion(records)
    path = write_records(records, args.output, require_motion=False)
    report = inspect_records(records, source=str(path))
    return {
        "input": str(args.path),
        "output": str(path),
        "format": got.facts.get("format", "table"),
        "n_records": len(records),
        "header_facts": got.facts,
        "mapping": got.mapping,
        "notes": got.notes + notes,
        "join": join,
        **{k: report[k] for k in ("heights_m", "time_span", "qc_preview", "blocking", "warnings")},
    }


def _convert_summary(out: dict) -> list[str]:
    """``flidar-uq convert``'s summary for people (the mapping itself with ``--json``)."""
    lines = [
        f"wrote {out['output']} from {out['input']}",
        "format: " + _format_words(out["format"], out["header_facts"]),
        f"{len(out['mapping'])} columns mapped; --json lists them",
    ]
    lines += _records_lines(out)
    lines += _join_lines(out["join"])
    return lines + [f"note: {n}" for n in out["notes"]]


# ---- generate-campaign ---------------------------------------------------------------------


def _nonnegative_int(text: str) -> int:
    try:
        x = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if x < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text!r}")
    return x


def _add_generate_campaign(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--scenario",
        default="default",
        help="shipped scenario name (flidar_uq/resources/scenarios/) or a YAML path; "
        "default 'default'",
    )
    p.add_argument("--seed", type=_nonnegative_int, default=0, help="root seed (SeedSequence)")
    p.add_argument("--output", required=True, help="output record table (.csv or .parquet)")
    p.add_argument("--imu-output", default=None, help="also write the raw IMU series here")
    p.add_argument("--workers", type=_nonnegative_int, default=None, help="worker processes")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")


def _run_generate_campaign(args: argparse.Namespace) -> dict:
    from flidar_uq.campaign.physics_mode import generate_campaign
    from flidar_uq.campaign.scenarios import load_scenario
    from flidar_uq.data.io import write_imu_series, write_records

    scenario = load_scenario(args.scenario)
    out = generate_campaign(
        scenario,
        args.seed,
        progress=not args.no_progress,
        return_imu=args.imu_output is not None,
        n_workers=args.workers or None,
    )
    path = write_records(out.records, args.output)
    result = {"output": str(path), "n_records": len(out.records), "seed": args.seed}
    if args.imu_output is not None:
        result["imu_output"] = str(write_imu_series(out.imu, args.imu_output))
    return result


# ---- run -----------------------------------------------------------------------------------


def _add_run(p: argparse.ArgumentParser) -> None:
    p.add_argument("--configfile", default=None, help="your config (YAML); default config/")
    p.add_argument("--cores", default="all", help="CPU cores Snakemake may use; default all")
    p.add_argument(
        "--directory",
        default=".",
        help="working directory of the run (its results/ go there); default the current one",
    )
    p.add_argument("--verbose", action="store_true", help="show Snakemake's own output unchanged")


def _run_pipeline(args: argparse.Namespace) -> int:
    from flidar_uq.workflow.inputs import load_config_file
    from flidar_uq.workflow.run_console import run_pipeline

    smk = ["--cores", str(args.cores), "--directory", args.directory]
    min_count = 10
    if args.configfile is not None:
        smk += ["--configfile", args.configfile]
        report = load_config_file(args.configfile).get("report") or {}
        min_count = int(report.get("group_min_count", min_count))
    return run_pipeline(
        smk + list(args.snakemake_args),
        workdir=args.directory,
        verbose=args.verbose,
        min_count=min_count,
    )


SUBCOMMANDS: dict[str, tuple[Callable, Callable, str]] = {
    "sigma-z": (
        _add_sigma_z,
        _run_sigma_z,
        "motion-induced HWS error std sigma_Z (Gutiérrez-Antuñano et al., 2018)",
    ),
    "validate": (_add_validate, _run_validate, "validate a record table (docs/data-format.md)"),
    "convert": (
        _add_convert,
        _run_convert,
        "write an instrument file (or a record table) as the documented record table",
    ),
    "generate-campaign": (
        _add_generate_campaign,
        _run_generate_campaign,
        "write a virtual campaign (physics mode) in the record format",
    ),
    "run": (
        _add_run,
        _run_pipeline,
        "run the pipeline (Snakemake) with one plain-words line per step and a summary; "
        "other arguments go to Snakemake",
    ),
}


def build_parser() -> argparse.ArgumentParser:
    """The ``flidar-uq`` parser with one subparser per entry of :data:`SUBCOMMANDS`."""
    from flidar_uq import __version__

    epilog = "exit status: " + "; ".join(f"{k} {v}" for k, v in sorted(EXIT_CODES.items()))
    parser = _OneLineParser(prog="flidar-uq", description=__doc__.splitlines()[0], epilog=epilog)
    parser.add_argument("--version", action="version", version=f"flidar-uq {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_OneLineParser)
    for name, (add, run, helptext) in SUBCOMMANDS.items():
        # no abbreviations for run: Snakemake's --config must not become --configfile
        p = sub.add_parser(
            name, help=helptext, description=helptext, epilog=epilog, allow_abbrev=name != "run"
        )
        add(p)
        p.set_defaults(_run=run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status (0 ok, 2 usage, 3 bad data, 1 internal error).

    The classes are :data:`flidar_uq.workflow.inputs.EXIT_CODES`.
    """
    parser = build_parser()
    try:
        args, extra = parser.parse_known_args(argv)
        if getattr(args, "_run", None) is None:
            raise CliError("flidar-uq: error: a command is required: " + ", ".join(SUBCOMMANDS))
        if extra and args.command != "run":
            raise CliError(f"flidar-uq: error: unrecognized arguments: {' '.join(extra)}")
        args.snakemake_args = extra
        result = args._run(args)
    except CliError as exc:
        print(str(exc), file=sys.stderr)
        return EXIT_USAGE
    except Exception as exc:  # noqa: BLE001 - the CLI never shows a traceback
        code = exit_status(exc)
        if code is not None:  # a config key or the data
            print(f"flidar-uq: error: {exc}", file=sys.stderr)
            return code
        if isinstance(exc, ValueError):  # misuse detected inside the library
            print(f"flidar-uq: error: {exc}", file=sys.stderr)
            return EXIT_USAGE
        if isinstance(exc, OSError):  # a file the command writes
            print(f"flidar-uq: error: {exc.filename or ''}: {_reason(exc)}", file=sys.stderr)
            return EXIT_DATA
        print(f"flidar-uq: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return EXIT_INTERNAL
    if isinstance(result, int):  # a command that printed its own output: its exit status
        return result
    summary = getattr(args, "_summary", None)
    if summary is not None and not args.json:
        print("\n".join(summary(result)))
        return EXIT_OK
    print(json.dumps(result))
    return EXIT_OK


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

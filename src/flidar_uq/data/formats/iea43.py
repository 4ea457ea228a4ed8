"""IEA Wind Task 43 WRA data model: a time series CSV described by its JSON metadata.

The metadata (the ``iea43_wra_data_model`` JSON) is either the file's header (the file
starts with the JSON document, the CSV follows) or a file of the same name ending in
``.json`` next to the data. It states, per logger (``logger_main_config``),
``offset_from_utc_hrs``, ``averaging_period_minutes`` and
``timestamp_is_end_of_period``, and per measurement point its ``measurement_type_id``,
``height_m`` and the data columns with their ``statistic_type_id``
(``logger_measurement_config[].column_name[]``). The CSV is comma-separated, its first
column the time stamp (ISO 8601, ``2022-03-01 12:10:00``).
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import pandas as pd

from flidar_uq.data.formats.common import (
    ParsedFile,
    availability_from_packets,
    numeric_columns,
    parse_stamps,
    read_text,
    resolve_offset_h,
    to_utc_start,
    with_timestamp,
)
from flidar_uq.data.io import DataValidationError, heading_ccw_deg

__all__ = ["looks_like", "is_metadata", "metadata_sidecar", "read", "TARGETS"]

#: (measurement_type_id, statistic_type_id) -> record column; None: any statistic
TARGETS = {
    ("wind_speed", "avg"): "hws_mean_ms",
    ("wind_speed", "sd"): "hws_std_ms",
    ("wind_speed", "count"): "packets_count",
    ("wind_speed", "availability"): "availability_pct",
    ("availability", None): "availability_pct",
    ("wind_direction", "avg"): "wd_mean_deg",
    ("wind_direction", "sd"): "wd_std_deg",
    ("carrier_to_noise_ratio", "avg"): "cnr_mean_db",
    ("wave_significant_height", None): "wave_hs_m",
    ("wave_peak_period", None): "wave_tp_s",
    ("wave_period", None): "wave_tm02_s",
    ("wave_direction", None): "wave_dir_deg",
    ("wave_directional_spread", None): "wave_spread_deg",
    ("compass_direction", "avg"): "heading_mean_deg",
    ("tilt_x", "sd"): "roll_std_deg",
    ("tilt_y", "sd"): "pitch_std_deg",
}
_FORMATS = ("ISO8601",)


def looks_like(head: str) -> bool:
    """Whether a text starts with a JSON document (the metadata header)."""
    return head.lstrip().startswith("{")


def is_metadata(meta) -> bool:
    """Whether a parsed JSON document is recognisably Task 43 metadata: an object whose
    ``measurement_location`` is a list of objects each with a ``logger_main_config`` or a
    ``measurement_point``."""
    locs = meta.get("measurement_location") if isinstance(meta, dict) else None
    return (
        isinstance(locs, list)
        and bool(locs)
        and all(
            isinstance(loc, dict) and ("logger_main_config" in loc or "measurement_point" in loc)
            for loc in locs
        )
    )


def metadata_sidecar(path: str | Path) -> Path | None:
    """The ``.json`` of the same name next to ``path`` when it is Task 43 metadata
    (:func:`is_metadata`); None when there is none or it is another JSON file."""
    side = Path(path).with_suffix(".json")
    if not side.is_file():
        return None
    try:
        return side if is_metadata(json.loads(read_text(side))) else None
    except (json.JSONDecodeError, OSError, UnicodeDecodeError):
        return None


def _split(text: str, path: Path) -> tuple[dict, str, int, str]:
    """(metadata, CSV text, file line of the CSV header, where the metadata came from)."""
    source = str(path)
    if looks_like(text):
        dec = json.JSONDecoder()
        start = len(text) - len(text.lstrip())
        try:
            meta, end = dec.raw_decode(text, start)
        except json.JSONDecodeError as exc:
            raise DataValidationError(
                source,
                None,
                None,
                f"truncated or malformed JSON header ({exc.msg})",
                line=exc.lineno,
            ) from None
        line = text.count("\n", 0, end) + 1
        rest = text[end:]
        skipped = len(rest) - len(rest.lstrip("\n \t"))
        line += rest[:skipped].count("\n")
        return meta, rest[skipped:], line, "header"
    side = path.with_suffix(".json")
    if not side.exists():
        raise DataValidationError(
            source,
            None,
            None,
            f"no IEA Task 43 metadata: neither a JSON header nor {side.name} next to the file",
            whole_file=True,
        )
    try:
        meta = json.loads(read_text(side))
    except json.JSONDecodeError as exc:
        raise DataValidationError(
            str(side), None, None, f"malformed JSON ({exc.msg})", line=exc.lineno
        ) from None
    if not is_metadata(meta):
        raise DataValidationError(
            str(side), None, "measurement_location",
            "not IEA Task 43 metadata (no measurement_location with a logger_main_config or "
            "measurement_point)", whole_file=True,
        )  # fmt: skip
    return meta, text, 1, side.name


def _loggers(meta: dict, source: str, utc_offset_h: float | None) -> dict:
    """Facts of the loggers: one offset, one averaging period and one stamp position."""
    try:
        loc = meta["measurement_location"][0]
    except (KeyError, IndexError, TypeError):
        raise DataValidationError(
            source, None, "measurement_location", "metadata without a measurement location",
            header=True,
        ) from None  # fmt: skip
    facts = {"location": loc.get("name")}
    seen: dict[str, tuple] = {}
    for lg in loc.get("logger_main_config") or []:
        name = lg.get("logger_name") or lg.get("logger_serial_number")
        facts.setdefault("serial_number", lg.get("logger_serial_number"))
        facts.setdefault("logger_model", lg.get("logger_model_name"))
        for key in (
            "offset_from_utc_hrs",
            "averaging_period_minutes",
            "timestamp_is_end_of_period",
        ):
            value = lg.get(key)
            if value is None:
                continue
            if key in seen and seen[key][1] != value:
                what = "UTC offsets" if key == "offset_from_utc_hrs" else f"values of {key}"
                raise DataValidationError(
                    source,
                    None,
                    key,
                    f"inconsistent {what}: logger {seen[key][0]!r} states {seen[key][1]!r}, "
                    f"logger {name!r} {value!r} (one time series has one convention)",
                    header=True,
                )
            seen.setdefault(key, (name, value))
    header_h = seen.get("offset_from_utc_hrs", (None, None))[1]
    facts["utc_offset_h"] = resolve_offset_h(
        header_h, utc_offset_h, source=source, line=1, key="offset_from_utc_hrs"
    )
    facts["averaging_period_min"] = seen.get("averaging_period_minutes", (None, None))[1]
    end = seen.get("timestamp_is_end_of_period", (None, None))[1]
    facts["timestamp_at"] = None if end is None else ("end" if end else "start")
    if facts["averaging_period_min"] not in (None, 10):
        raise DataValidationError(
            source, None, "averaging_period_minutes",
            f"averaging period {facts['averaging_period_min']} min: records are 10-min "
            "statistics", header=True,
        )  # fmt: skip
    return facts


def _targets(meta: dict) -> list[tuple[str, float | None, str]]:
    """(data column, height in m or None for shared, record column) of the metadata."""
    out = []
    for mp in meta["measurement_location"][0].get("measurement_point") or []:
        mtype = mp.get("measurement_type_id")
        h = mp.get("height_m")
        for cfg in mp.get("logger_measurement_config") or []:
            for col in cfg.get("column_name") or []:
                if col.get("is_ignored"):
                    continue
                stat = col.get("statistic_type_id")
                target = TARGETS.get((mtype, stat)) or TARGETS.get((mtype, None))
                if target is None:
                    continue
                height = float(h) if h is not None and float(h) > 0 else None
                if target.startswith(("wave_", "heading", "roll_", "pitch_")):
                    height = None
                out.append((col["column_name"], height, target))
    return out


def read(
    path: Path, *, utc_offset_h: float | None = None, timestamp_at: str | None = None
) -> ParsedFile:
    """Read an IEA Task 43 data file with its metadata (parameters as
    :func:`windcube.read`; the metadata's statements win and must agree with the config)."""
    source = str(path)
    meta, csv_text, header_line, where = _split(read_text(path), path)
    facts = _loggers(meta, source, utc_offset_h)
    facts["metadata"] = where
    at = facts["timestamp_at"] or timestamp_at or "start"
    facts["timestamp_at"] = at
    lines = csv_text.split("\n")
    header = [h.strip() for h in lines[0].split(",")] if lines else []
    for i, ln in enumerate(lines[1:]):
        if ln.strip() and ln.count(",") != len(header) - 1:
            k = min(ln.count(",") + 1, len(header) - 1)
            hint = " (';' or tabs here? the file uses ',')" if (";" in ln or "\t" in ln) else ""
            raise DataValidationError(
                source, i + 1, header[k],
                f"{ln.count(',') + 1} comma-separated fields where the column line has "
                f"{len(header)}{hint}",
                line=header_line + 1 + i,
            )  # fmt: skip
    table = pd.read_csv(io.StringIO(csv_text), dtype=object, skip_blank_lines=True)
    time_col = header[0]
    local = parse_stamps(
        table.pop(time_col), _FORMATS, source=source, column=time_col, first_line=header_line + 1
    )
    table = with_timestamp(
        table, to_utc_start(local, utc_offset_h=facts["utc_offset_h"], at_end=at == "end")
    )
    table = numeric_columns(table, decimal_comma=False)
    per_height: dict[float, dict[str, str]] = {}
    shared = {c: c for c in table.columns[1:]}
    notes = []
    for col, h, target in _targets(meta):
        if col not in table.columns:
            raise DataValidationError(
                source, None, col,
                f"column missing although the metadata lists it ({target}"
                + (f" at {h:g} m)" if h is not None else ")"),
                line=header_line,
            )  # fmt: skip
        shared.pop(col, None)
        if target == "heading_mean_deg":
            table[col] = heading_ccw_deg(table[col].to_numpy(dtype=float))
            notes.append(f"heading_mean_deg from {col!r}, a compass direction turned ccw")
        if h is None:
            shared[col] = target
        else:
            per_height.setdefault(h, {})[col] = target
    facts["heights_m"] = sorted(per_height)
    notes += availability_from_packets(table, per_height)
    return ParsedFile(table, per_height, shared, facts, header_line + 1, "iea43", notes)

"""The text ``DataFrame.to_csv`` writes, built column by column.

pandas formats each value through several Python calls (~1.5 us a float with a
``float_format``; numpy's float-to-text without one, ~1 us), most of a data step's time at a
year of records. This builds the same bytes in one call per value (~0.3 us), once per run
of equal values (a record table repeats each record's values over its heights), and leaves
to pandas whatever it does not reproduce exactly (returns None).
"""

from __future__ import annotations

import csv
import io
import re

import numpy as np
import pandas as pd

__all__ = ["csv_text"]

#: a field that CSV may quote (QUOTE_MINIMAL; Python 3.13's csv quotes a lone "\r", 3.12's not)
_MAY_NEED_QUOTES = re.compile('[,"\r\n]')


def _quoted(text: str) -> str:
    """``text`` as a CSV field, as pandas writes it: through Python's csv writer (the one
    ``to_csv`` uses, its dialect) when it holds a delimiter, quote or line break."""
    if not _MAY_NEED_QUOTES.search(text):
        return text
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerow([text, ""])
    return buffer.getvalue()[:-2]  # the row is the field, "," and the terminator


def _column_text(col: pd.Series, float_format: str | None, date_format: str) -> list[str] | None:
    """The CSV fields of one column as ``to_csv`` writes them (``float_format``; None: the
    shortest text that reads back the same float64, numpy's ``astype(str)`` = ``repr``;
    missing values empty, QUOTE_MINIMAL), or None for a dtype left to pandas."""
    dt = col.dtype
    if isinstance(dt, np.dtype) and dt.kind == "f":
        if float_format is None and dt != np.float64:
            return None  # numpy's shortest float32 text is not repr's
        values = col.to_numpy()
        if float_format is None:
            fmt = repr
        else:

            def fmt(v):
                return float_format % v

        # a run of equal values (the same bits: -0.0 and 0.0 differ) is formatted once:
        # a record table repeats each record's value over its heights
        first = None
        if values.dtype.itemsize in (2, 4, 8):  # a matching integer type (not longdouble)
            bits = values.view(f"i{values.dtype.itemsize}")
            new_run = np.ones(values.size, bool)
            np.not_equal(bits[1:], bits[:-1], out=new_run[1:])
            first = np.flatnonzero(new_run)
        if first is not None and 2 * first.size < values.size:
            distinct = np.array(list(map(fmt, values[first].tolist())) + [""], dtype=object)
            run = np.cumsum(new_run) - 1
            run[np.isnan(values)] = first.size  # missing: ""
            return distinct[run].tolist()
        text = list(map(fmt, values.tolist()))
        for i in np.flatnonzero(np.isnan(values)).tolist():
            text[i] = ""
        return text
    if isinstance(dt, np.dtype) and dt.kind in "iub":
        return list(map(str, col.tolist()))
    if isinstance(dt, pd.DatetimeTZDtype) or (isinstance(dt, np.dtype) and dt.kind == "M"):
        return col.dt.strftime(date_format).fillna("").tolist()
    if isinstance(dt, pd.CategoricalDtype):
        categories = dt.categories
        if not (categories.dtype.kind == "O" or isinstance(categories.dtype, pd.StringDtype)):
            return None
        labels = categories.tolist()
        if not all(isinstance(v, str) for v in labels):
            return None
        labels = [_quoted(v) for v in labels] + [""]  # code -1: missing
        return [labels[c] for c in col.cat.codes.tolist()]
    if isinstance(dt, pd.StringDtype) or (isinstance(dt, np.dtype) and dt.kind == "O"):
        values = col.tolist()
        if all(isinstance(v, str) for v in values if not pd.isna(v)):
            return ["" if not isinstance(v, str) else _quoted(v) for v in values]
    return None


def csv_text(df: pd.DataFrame, *, float_format: str | None, date_format: str) -> str | None:
    """The text ``df.to_csv(index=False, float_format=float_format, date_format=date_format,
    lineterminator="\\n")`` writes, or None when a column (nullable integers, mixed objects,
    float32 without a format, ...), the header or the shape is left to pandas: duplicated or
    non-text column names, fewer than two columns (CSV quotes a lone empty field)."""
    if df.shape[1] < 2 or not all(isinstance(c, str) for c in df.columns):
        return None
    if df.columns.duplicated().any():
        return None
    columns = []
    for c in df.columns:
        text = _column_text(df[c], float_format, date_format)
        if text is None:
            return None
        columns.append(text)
    lines = [",".join(map(_quoted, df.columns))]
    lines.extend(map(",".join, zip(*columns, strict=True)))
    return "\n".join(lines) + "\n"

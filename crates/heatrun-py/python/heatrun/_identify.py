"""Data not in MCAP: a table in memory turned into a recording of the profile by the
library's own import (what ``heatrun import TABLE --map MAP`` does), then replayed.

The frame is written as a CSV with every float in 17 significant digits (which read back
as the same double) and a map naming each column's channel, unit and interpolation; the
library imports it into a temporary MCAP and replays that. A table given to the command
line as a CSV and a map therefore gives the same model as the same table read with pandas
and given here.
"""

from __future__ import annotations

import os
import re
import tempfile
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from . import _heatrun
from ._report import PathLike, Report


def _frame(data: Any) -> Any:
    """A DataFrame of ``data`` (a DataFrame, or a dict of arrays whose ``time`` or
    ``time_s`` entry becomes the index)."""
    import pandas as pd

    if isinstance(data, pd.DataFrame):
        return data
    if isinstance(data, Mapping):
        frame = pd.DataFrame({k: np.asarray(v) for k, v in data.items()})
        for key in ("time", "time_s"):
            if key in frame.columns:
                return frame.set_index(key)
        raise _heatrun.BadInputError(
            "a dict of arrays needs its times under the key 'time' (seconds, or datetime64)"
        )
    raise _heatrun.BadInputError(
        f"identify takes a pandas DataFrame or a dict of arrays, not {type(data).__name__}"
    )


def _time_column(index: Any) -> Tuple[List[str], str]:
    """The index as the time column's cells and the map's time format: numbers of
    seconds as they are (17 digits), datetimes as RFC 3339 in UTC (naive ones taken as
    UTC), time deltas as seconds."""
    import pandas as pd

    if isinstance(index, pd.DatetimeIndex):
        utc = index.tz_convert("UTC") if index.tz is not None else index.tz_localize("UTC")
        return [t.strftime("%Y-%m-%dT%H:%M:%S.%f") + f"{t.nanosecond:03d}Z" for t in utc], "timestamp"
    if isinstance(index, pd.TimedeltaIndex):
        return [repr(float(s)) for s in index.total_seconds()], "seconds"
    values = np.asarray(index)
    if not np.issubdtype(values.dtype, np.number):
        raise _heatrun.BadInputError(
            "the frame's index must be the time: seconds (numbers), datetimes or time deltas; "
            f"it holds {values.dtype}"
        )
    return [repr(float(v)) for v in values], "seconds"


def _toml_string(text: str) -> str:
    """A TOML basic string."""
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def write_recording(
    data: Any,
    out: PathLike,
    *,
    spec: Optional[PathLike] = None,
    field_state: bool = False,
    units: Optional[Mapping[str, str]] = None,
    interpolation: Optional[Mapping[str, str]] = None,
    metadata: Optional[Mapping[str, Mapping[str, str]]] = None,
) -> int:
    """Writes the columns of ``data`` that the model of ``spec`` reads into the profile
    recording ``out`` through the library's import; returns the messages written.

    ``units``: a column's unit where it is not the default (a state's unit as the spec
    gives it, °C by default; a profile quantity's canonical unit; else ``"1"``).
    ``interpolation``: ``"step"`` for a column held between its samples (a command, a set
    point), ``"linear"`` (the default) otherwise. NaN cells are missing samples."""
    frame = _frame(data)
    wanted = _heatrun.spec_channels(None if spec is None else os.fspath(spec), field_state)
    units = dict(units or {})
    interpolation = dict(interpolation or {})
    columns = [str(c) for c in frame.columns]
    missing = [name for name, _ in wanted if name not in columns]
    if missing:
        raise _heatrun.BadInputError(
            f"the frame has no column {missing[0]!r}, which the model reads "
            f"(it has {', '.join(columns) or 'no columns'})"
        )
    for name in list(units) + list(interpolation):
        if name not in dict(wanted):
            raise _heatrun.BadInputError(
                f"{name!r} is not a channel the model reads ({', '.join(n for n, _ in wanted)})"
            )
    times, time_format = _time_column(frame.index)
    lines = ["time," + ",".join(name for name, _ in wanted)]
    cells = []
    for name, _ in wanted:
        values = np.asarray(frame[name], dtype=float)
        cells.append(["" if not np.isfinite(v) else repr(float(v)) for v in values])
    for k, t in enumerate(times):
        lines.append(t + "," + ",".join(c[k] for c in cells))
    map_lines = [
        "[input]",
        'delimiter = ","',
        "header = true",
        "[time]",
        "column = 1",
        f'format = "{time_format}"',
    ]
    for i, (name, default_unit) in enumerate(wanted):
        map_lines += [
            "[[column]]",
            f"column = {i + 2}",
            f"channel = {_toml_string(name)}",
            f"unit = {_toml_string(units.get(name, default_unit))}",
        ]
        if name in interpolation:
            map_lines.append(f"interpolation = {_toml_string(interpolation[name])}")
    for record, entries in (metadata or {}).items():
        map_lines.append(f"[metadata.{_toml_string(record)}]")
        map_lines += [f"{_toml_string(k)} = {_toml_string(str(v))}" for k, v in entries.items()]
    with tempfile.TemporaryDirectory(prefix="heatrun-") as folder:
        table = os.path.join(folder, "frame.csv")
        with open(table, "w", encoding="utf-8") as f:
            f.write("\n".join(lines) + "\n")
        try:
            return _heatrun.import_table(table, "\n".join(map_lines) + "\n", "frame.map.toml", os.fspath(out))
        except _heatrun.HeatrunError as e:
            # The import names the temporary table's line: say the frame's row instead
            # (the header is line 1, row 0 is line 2).
            where = re.compile(re.escape(table) + r": line (\d+)")
            message = where.sub(lambda m: f"the frame's row {int(m.group(1)) - 2} (from 0)", str(e))
            raise type(e)(message) from None


def identify(
    frame: Any,
    *,
    spec: Optional[PathLike],
    ts: Optional[float] = None,
    units: Optional[Mapping[str, str]] = None,
    interpolation: Optional[Mapping[str, str]] = None,
    method: Optional[str] = None,
    field_state: bool = False,
    reference: str = "auto",
    machine: Optional[PathLike] = None,
    network: str = "best",
    weights: Optional[Sequence[float]] = None,
    forgetting: float = 1.0,
    holdout: Optional[float] = None,
    split_at: Optional[float] = None,
    validate: Any = None,
    recording: Optional[PathLike] = None,
) -> Report:
    """Identifies the model of ``spec`` from a table in memory: a pandas DataFrame (or a
    dict of numpy arrays) indexed by time (seconds, datetimes or time deltas) with a
    column per channel the spec reads (its states' and inputs'), named as the spec names
    them. Other columns are not read.

    The options are :func:`heatrun.replay`'s; ``validate`` may also be a frame of the
    same channels. ``units`` and ``interpolation`` are as in ``heatrun import``'s map
    (:func:`write_recording`). The recording is written to a temporary file, or kept at
    ``recording`` where given."""
    from . import replay

    with tempfile.TemporaryDirectory(prefix="heatrun-") as folder:
        out = os.fspath(recording) if recording is not None else os.path.join(folder, "frame.mcap")
        options: Dict[str, Any] = dict(spec=spec, field_state=field_state, units=units, interpolation=interpolation)
        write_recording(frame, out, **options)
        if validate is not None and not isinstance(validate, (str, os.PathLike)):
            validation = os.path.join(folder, "validation.mcap")
            write_recording(validate, validation, **options)
            validate = validation
        return replay(
            out,
            spec=spec,
            ts=ts,
            method=method,
            field_state=field_state,
            reference=reference,
            machine=machine,
            network=network,
            weights=weights,
            forgetting=forgetting,
            holdout=holdout,
            split_at=split_at,
            validate=validate,
        )

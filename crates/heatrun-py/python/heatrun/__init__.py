"""heatrun from Python: thermal system identification of hydro generators (and of any
thermal system a spec describes) from heat-run recordings, with the library of the
``heatrun`` command.

- :func:`replay` identifies the model of an MCAP recording, as ``heatrun replay`` does;
- :func:`identify` does the same for a pandas DataFrame (or a dict of numpy arrays);
- both give a :class:`Report`: the report's content as typed attributes, the traces as a
  DataFrame, and the uses of the model (:meth:`Report.predict`, :meth:`Report.rating`);
- :func:`fleet_summary` and :func:`fleet_compare` reduce many reports (e.g. gathered from
  a Dask or Ray cluster) into ``heatrun fleet summary``'s table and ``heatrun fleet
  compare``'s comparison.

The library works with the GIL released, so threads replay in parallel. Its errors are
raised as :class:`HeatrunError` with the command line's one-line message;
:class:`BadInputError` (a subclass) is the input's fault (the command line's exit
status 2).
"""

from __future__ import annotations

import io
import json
import os
from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple, Union

from . import _heatrun
from ._heatrun import BadInputError, HeatrunError
from ._identify import identify, write_recording
from ._report import Fit, Network, PathLike, Report, SteadyState, TimeConstant, load_report

__version__: str = _heatrun.version()

__all__ = [
    "BadInputError",
    "Fit",
    "HeatrunError",
    "Network",
    "Report",
    "SteadyState",
    "TimeConstant",
    "fleet_compare",
    "fleet_summary",
    "identify",
    "list_recordings",
    "load_report",
    "replay",
    "write_recording",
]


def replay(
    path_or_url: PathLike,
    *,
    method: Optional[str] = None,
    spec: Optional[PathLike] = None,
    field_state: bool = False,
    reference: str = "auto",
    network: str = "best",
    ts: Optional[float] = None,
    machine: Optional[PathLike] = None,
    weights: Optional[Sequence[float]] = None,
    forgetting: float = 1.0,
    holdout: Optional[float] = None,
    split_at: Optional[float] = None,
    validate: Optional[PathLike] = None,
    traces: bool = True,
) -> Report:
    """Identifies the thermal model of one recording (MCAP, heatrun SCADA profile; a path,
    or a URL where the package is built with object storage), as ``heatrun replay`` does
    with the same options, and returns its report.

    The options and their defaults are the command line's:

    - ``method``: ``"oe"``, ``"pem"``, ``"rc"``, ``"iv"``, ``"rls"``, ``"wls"``, ``"ls"``
      [default: the spec's, else oe, or pem where oe's residuals are not white];
    - ``spec``: a model spec (TOML) [default: the hydro generator of the profile];
    - ``field_state``: the field winding as a fourth state (not with ``spec``);
    - ``reference``: what the rises are measured from, ``"auto"``, ``"initial"`` or
      ``"inlet"``;
    - ``network``: ``"best"`` (rc's fit where the data tell the nearest passive network
      from the model) or ``"nearest"`` (faster);
    - ``ts``: the sample time, s [default: the spec's, else 1];
    - ``machine``: a machine file (TOML) whose keys override the recording's nameplate;
    - ``weights``: per-state weights of wls and oe; ``forgetting``: rls's λ;
    - ``holdout`` (a fraction), ``split_at`` (s) or ``validate`` (another recording):
      where the model's fit on data it was not estimated from is measured.

    ``traces=False`` keeps no traces (:meth:`Report.traces`), for fleets."""
    path = os.fspath(path_or_url)
    out = _heatrun.replay(
        path,
        method=method,
        spec=None if spec is None else os.fspath(spec),
        field_state=field_state,
        reference=reference,
        machine=None if machine is None else os.fspath(machine),
        network=network,
        ts=None if ts is None else float(ts),
        weights=None if weights is None else [float(w) for w in weights],
        forgetting=float(forgetting),
        holdout=holdout,
        split_at=split_at,
        validate=None if validate is None else os.fspath(validate),
        traces=traces,
    )
    # Messages about the report (a use of the model that cannot be made) name it by its
    # recording.
    return Report(
        out["report_json"], summary=out["summary"], traces=out.get("traces"), name=f"the report of {path}"
    )


def list_recordings(folder_or_prefix: PathLike) -> List[str]:
    """The recordings (``.mcap``) of a folder, or of an object-store prefix (a URL ending
    in ``/``, where the package is built with object storage), sorted by name: the fleet
    ``heatrun replay FOLDER`` replays, named as it names them."""
    return _heatrun.list_recordings(os.fspath(folder_or_prefix))


def _report_texts(reports: Iterable[Union[Report, str, "os.PathLike[str]"]]) -> List[Tuple[str, str]]:
    """(name, JSON text) of each report: a :class:`Report`, a report's JSON text, or the
    path of a report file."""
    out = []
    for r in reports:
        if isinstance(r, Report):
            out.append((str(r.recording.get("path", r._name)), r.to_json()))
        elif isinstance(r, str) and r.lstrip().startswith("{"):
            out.append((str(json.loads(r).get("recording", {}).get("path", "report")), r))
        else:
            name = os.fspath(r)
            with open(name, encoding="utf-8") as f:
                out.append((name, f.read()))
    return out


def fleet_summary(reports: Iterable[Union[Report, str, "os.PathLike[str]"]]) -> Any:
    """The fleet table of many reports (:class:`Report` objects, report JSON texts, or
    report files), in the order given: the table ``heatrun fleet summary`` writes to
    ``fleet-summary.csv`` for the same reports (one row per recording: its status, time
    constants, fit and steady state per state), as a DataFrame. The CSV text itself is in
    ``frame.attrs["csv"]`` and the table as printed in ``frame.attrs["text"]``."""
    import csv as csv_module

    import pandas as pd

    csv, text = _heatrun.fleet_summary_csv(_report_texts(reports))
    # Each figure read by Python's float, which reads the shortest digits the library
    # writes back to the same double (pandas' own parser may not, before pandas 3).
    header, *rows = list(csv_module.reader(io.StringIO(csv)))
    columns: Dict[str, List[Any]] = {name: [] for name in header}
    for row in rows:
        for name, cell in zip(header, row):
            if name in ("recording", "status"):
                columns[name].append(cell)
            else:
                columns[name].append(float(cell) if cell else float("nan"))
    frame = pd.DataFrame(columns, columns=header)
    frame.attrs["csv"] = csv
    frame.attrs["text"] = text
    return frame


def fleet_compare(
    reports: Iterable[Union[Report, str, "os.PathLike[str]"]],
    *,
    labels: Optional[Sequence[str]] = None,
    threshold: Optional[float] = None,
    floor: Optional[float] = None,
) -> Dict[str, Any]:
    """``heatrun fleet compare`` on many reports of same-design units: each quantity (time
    constants, steady-state and rated rises, network, fit) scored against the rest of the
    fleet, and the units that differ beyond the fleet's spread and their own uncertainty
    named. Returns the comparison as ``--json`` writes it (``"reports"``, ``"options"``,
    ``"table"``, ``"outliers"``), with ``"scores"``, a DataFrame of the table (one row per
    unit and quantity), and ``"summary"``, as printed.
    ``threshold`` and ``floor`` default to the command line's (8 and 1 %)."""
    import pandas as pd

    texts = _report_texts(reports)
    if labels is not None:
        labels = [str(label) for label in labels]
        if len(labels) != len(texts):
            raise BadInputError(f"{len(labels)} labels for {len(texts)} reports")
        texts = [(label, text) for label, (_, text) in zip(labels, texts)]
    text, summary = _heatrun.fleet_compare(texts, threshold=threshold, floor=floor)
    comparison: Dict[str, Any] = json.loads(text)
    rows = []
    for q in comparison["table"]:
        for unit, scored in zip(comparison["reports"], q["units"]):
            rows.append({"report": unit, "quantity": q["quantity"], **scored})
    comparison["scores"] = pd.DataFrame(rows)
    comparison["summary"] = summary
    return comparison

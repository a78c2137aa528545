"""Type stubs of the extension module `heatrun._heatrun` (the Rust half of the package).

The public API is the package's (`heatrun.replay`, `heatrun.identify`, `heatrun.Report`,
...); these are the functions it calls.
"""

from typing import Any, Dict, List, Optional, Sequence, Tuple

__all__ = [
    "HeatrunError",
    "BadInputError",
    "replay",
    "import_table",
    "read_report",
    "check_report",
    "version",
    "spec_channels",
    "list_recordings",
    "predict",
    "rating",
    "fleet_summary_csv",
    "fleet_compare",
]

class HeatrunError(Exception):
    """An error of heatrun's library, with the command line's one-line message."""

class BadInputError(HeatrunError):
    """The input's fault (a bad file, channel, row, key or option): the command line's exit status 2."""

def replay(
    path: str,
    *,
    method: Optional[str] = None,
    spec: Optional[str] = None,
    field_state: bool = False,
    reference: str = "auto",
    machine: Optional[str] = None,
    network: str = "best",
    ts: Optional[float] = None,
    weights: Optional[Sequence[float]] = None,
    forgetting: float = 1.0,
    holdout: Optional[float] = None,
    split_at: Optional[float] = None,
    validate: Optional[str] = None,
    traces: bool = True,
) -> Dict[str, Any]: ...
def import_table(table: str, map_toml: str, map_name: str, out: str) -> int: ...
def read_report(path: str) -> str: ...
def check_report(text: str, name: str) -> None: ...
def version() -> str: ...
def spec_channels(spec: Optional[str] = None, field_state: bool = False) -> List[Tuple[str, str]]: ...
def predict(
    report_json: str,
    name: str,
    load_csv: str,
    *,
    initial: str = "measured",
    initial_temps: Optional[Sequence[float]] = None,
) -> Dict[str, Any]: ...
def rating(
    report_json: str,
    name: str,
    *,
    insulation_class: Optional[str] = None,
    limits: Sequence[Tuple[str, float]] = ...,
    power_factor: Optional[float] = None,
    voltage_kv: Optional[float] = None,
    coolant_c: Optional[float] = None,
    overloads_percent: Sequence[float] = ...,
) -> Tuple[str, str]: ...
def fleet_summary_csv(reports: Sequence[Tuple[str, str]]) -> Tuple[str, str]: ...
def fleet_compare(
    units: Sequence[Tuple[str, str]],
    *,
    threshold: Optional[float] = None,
    floor: Optional[float] = None,
) -> Tuple[str, str]: ...
def list_recordings(folder: str) -> List[str]: ...

"""The report of a replay as a Python object: typed attributes over the report's JSON.

The JSON (profile section "Report", what ``heatrun replay --report`` writes) stays the
source: :attr:`Report.data` is all of it as a dict, so a section this module does not know
(added by a later heatrun) is there as it was written, and :meth:`Report.to_json` gives the
text back unchanged. The attributes below are views of it: matrices as numpy arrays, one
value per state or time constant as lists of floats (printed as the command line's JSON
prints them).
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _heatrun

PathLike = Union[str, "os.PathLike[str]"]


def _matrix(rows: Optional[Sequence[Sequence[Optional[float]]]]) -> np.ndarray:
    """A row-major list of lists as a 2-D float array (JSON's null, a figure JSON could
    not hold, as NaN)."""
    if not rows:
        return np.zeros((0, 0))
    return np.array([[np.nan if v is None else v for v in row] for row in rows], dtype=float)


def _floats(values: Optional[Sequence[Optional[float]]]) -> List[float]:
    """A JSON list of numbers as floats (null as NaN)."""
    return [float("nan") if v is None else float(v) for v in (values or [])]


@dataclass(frozen=True)
class TimeConstant:
    """One time constant of the model, T_i = −1/Re λ_i (s), with the part it belongs to
    (the state whose response it dominates, by the sensitivity ‖T_i ∂y/∂T_i‖, paper
    eqs. 27-29) and its 95 % interval where the method gives a covariance."""

    #: T_i, s.
    value_s: float
    #: The 95 % interval's half-width, s (delta method, or oe's sandwich), if any.
    ci95_s: Optional[float]
    #: The part (the assigned state's ``part``).
    part: str
    #: The assigned state's name.
    state: str
    #: ‖T_i ∂y/∂T_i‖ of the assigned state (RMS, pu).
    sensitivity_norm: float
    #: 2π/|Im λ| for an oscillating mode (a complex pair), else None.
    oscillation_period_s: Optional[float] = None

    @property
    def interval_s(self) -> Optional[Tuple[float, float]]:
        """The 95 % interval (low, high), s, where there is one."""
        if self.ci95_s is None:
            return None
        return (self.value_s - self.ci95_s, self.value_s + self.ci95_s)


@dataclass(frozen=True)
class Fit:
    """How the model's simulation from the initial state fits the measured states: one
    value per state, in the model's order."""

    #: Signal-to-noise ratio, dB.
    snr_db: List[float]
    #: NRMSE fit, %: 100·(1 − ‖y − ŷ‖/‖y − ȳ‖).
    nrmse_fit_percent: List[float]
    #: Root-mean-square error, K.
    rmse_k: List[float]
    #: Largest absolute error, K.
    max_abs_error_k: List[float]
    #: Instants compared.
    samples: int

    @classmethod
    def _of(cls, block: Dict[str, Any]) -> "Fit":
        return cls(
            snr_db=_floats(block.get("snr_db")),
            nrmse_fit_percent=_floats(block.get("nrmse_fit_percent")),
            rmse_k=_floats(block.get("rmse_k")),
            max_abs_error_k=_floats(block.get("max_abs_error_k")),
            samples=int(block.get("samples", 0)),
        )


@dataclass(frozen=True)
class SteadyState:
    """The model's steady state at the final load (x_ss = (I − Φ)⁻¹ Γ u_final), one value
    per state, beside the measured final values."""

    #: The input held, in the model's units.
    input_pu: List[float]
    #: Steady rise over the reference, K.
    rise_k: List[float]
    #: Steady temperature, °C.
    temperature_c: List[float]
    #: Its 95 % half-width, K, where the method gives a covariance.
    ci95_k: Optional[List[float]]
    #: The last measured temperature, °C.
    measured_final_temperature_c: List[float]
    #: The last measured rise, K.
    measured_final_rise_k: List[float]
    #: Against the coolant inlet, where the states are measured from it.
    coolant_inlet: Optional[Dict[str, Any]]


@dataclass(frozen=True)
class Network:
    """The passive thermal network drawn beside the model (Fig. 9 of the paper), or the
    reason there is none. ``data`` is the report's ``network`` block as written."""

    #: Whether the model has a network (heat inputs, a passive fit).
    defined: bool
    #: Why there is none, where there is none.
    not_defined: Optional[str]
    #: Heat capacities C_i, J/K (NaN where the report has none).
    capacitance_j_per_k: np.ndarray
    #: Conductances G_ij, W/K (NaN where the report has none).
    conductance_w_per_k: np.ndarray
    #: The loss distribution K (which share of each input heats which node).
    loss_distribution: np.ndarray
    #: The whole block.
    data: Dict[str, Any]

    @classmethod
    def _of(cls, block: Optional[Dict[str, Any]]) -> Optional["Network"]:
        if block is None:
            return None
        if "not_defined" in block and len(block) == 1:
            return cls(False, str(block["not_defined"]), np.zeros(0), np.zeros((0, 0)), np.zeros((0, 0)), block)
        return cls(
            defined=True,
            not_defined=None,
            capacitance_j_per_k=np.array(_floats(block.get("capacitance_j_per_k")), dtype=float),
            conductance_w_per_k=_matrix(block.get("conductance_w_per_k")),
            loss_distribution=_matrix(block.get("loss_distribution")),
            data=block,
        )


class Report:
    """A replay's report (the profile's section "Report"): what ``heatrun replay --report``
    writes, as typed attributes, the whole as :attr:`data`, the text as :meth:`to_json`.

    Made by :func:`heatrun.replay`, :func:`heatrun.identify` (which also keep the traces on
    the grid, :meth:`traces`) or :func:`heatrun.load_report`."""

    def __init__(
        self,
        json_text: str,
        *,
        summary: Optional[str] = None,
        traces: Optional[Dict[str, Any]] = None,
        name: str = "report",
    ) -> None:
        _heatrun.check_report(json_text, name)
        self._text = json_text
        self._name = name
        self._summary = summary
        self._traces = traces
        #: The whole report as a dict (every section, known to this version or not).
        self.data: Dict[str, Any] = json.loads(json_text)

    # --- the model ---------------------------------------------------------------------

    @property
    def profile(self) -> str:
        """The profile the report is written against (``heatrun-scada/…``)."""
        return str(self.data["profile"])

    @property
    def heatrun_version(self) -> str:
        """The version of heatrun that wrote it."""
        return str(self.data.get("heatrun_version", ""))

    @property
    def sample_time_s(self) -> float:
        """The model's sample time Ts, s."""
        return float(self.data["sample_time_s"])

    @property
    def method(self) -> str:
        """The identification method (oe, pem, rc, iv, rls, wls, ls)."""
        return str(self.data.get("method", ""))

    @property
    def states(self) -> List[str]:
        """The states' names, in the model's order."""
        return list(self.data["states"])

    @property
    def inputs(self) -> List[str]:
        """The inputs' names, in the model's order."""
        return list(self.data["inputs"])

    @property
    def phi(self) -> np.ndarray:
        """Φ (n × n): x(k+1) = Φ x(k) + Γ u(k)."""
        return _matrix(self.data["phi"])

    @property
    def gamma(self) -> np.ndarray:
        """Γ (n × m)."""
        return _matrix(self.data["gamma"])

    @property
    def a_c(self) -> np.ndarray:
        """A_c (n × n, 1/s): dx/dt = A_c x + B_c u, Φ = e^{A_c Ts}."""
        return _matrix(self.data.get("a_c"))

    @property
    def b_c(self) -> np.ndarray:
        """B_c (n × m, 1/s)."""
        return _matrix(self.data.get("b_c"))

    @property
    def eigenvalues_discrete(self) -> np.ndarray:
        """Eigenvalues of Φ (complex where the report has imaginary parts)."""
        return self._eigenvalues("eigenvalues_discrete")

    @property
    def eigenvalues_continuous(self) -> np.ndarray:
        """Eigenvalues of A_c, 1/s (complex where the report has imaginary parts)."""
        return self._eigenvalues("eigenvalues_continuous")

    def _eigenvalues(self, key: str) -> np.ndarray:
        real = np.array(_floats(self.data.get(key)), dtype=float)
        imag = self.data.get(key + "_imag")
        if imag is None:
            return real
        return real + 1j * np.array(_floats(imag), dtype=float)

    @property
    def time_constants_s(self) -> List[float]:
        """The time constants T_i = −1/Re λ_i, s, ascending (the report's figures)."""
        return _floats(self.data["time_constants_s"])

    @property
    def time_constants(self) -> List[TimeConstant]:
        """The time constants with their parts and 95 % intervals, ascending."""
        ci = (self.data.get("uncertainty") or {}).get("time_constants_ci95_s")
        periods = self.data.get("oscillation_periods_s")
        out = []
        assignment = self.data.get("assignment") or []
        for i, t in enumerate(self.time_constants_s):
            a = assignment[i] if i < len(assignment) else {}
            out.append(
                TimeConstant(
                    value_s=t,
                    ci95_s=None if ci is None or ci[i] is None else float(ci[i]),
                    part=str(a.get("part", "")),
                    state=str(a.get("state", "")),
                    sensitivity_norm=float(a.get("sensitivity_norm", float("nan"))),
                    oscillation_period_s=None if not periods or periods[i] is None else float(periods[i]),
                )
            )
        return out

    @property
    def sensitivity_norms(self) -> np.ndarray:
        """‖T_i ∂y_k/∂T_i‖ (RMS, pu): rows states, columns time constants."""
        return _matrix(self.data.get("sensitivity_norms"))

    @property
    def fit(self) -> Fit:
        """The model's fit on the estimation data."""
        return Fit._of(self.data["fit"])

    @property
    def validation(self) -> Optional[Dict[str, Any]]:
        """The fit on held-out data or another recording (``source`` and ``fit``), if any."""
        v = self.data.get("validation")
        if v is None:
            return None
        return {"source": v.get("source"), "fit": Fit._of(v.get("fit", {}))}

    @property
    def steady_state(self) -> SteadyState:
        """The steady state at the final load."""
        s = self.data.get("steady_state") or {}
        ci = (self.data.get("uncertainty") or {}).get("steady_state_ci95_k")
        return SteadyState(
            input_pu=_floats(s.get("input_pu")),
            rise_k=_floats(s.get("rise_k")),
            temperature_c=_floats(s.get("temperature_c")),
            ci95_k=None if ci is None else _floats(ci),
            measured_final_temperature_c=_floats(s.get("measured_final_temperature_c")),
            measured_final_rise_k=_floats(s.get("measured_final_rise_k")),
            coolant_inlet=s.get("coolant_inlet"),
        )

    @property
    def network(self) -> Optional[Network]:
        """The thermal network (or why there is none); None in a report without one."""
        return Network._of(self.data.get("network"))

    @property
    def warnings(self) -> List[str]:
        """The replay's warnings (data loss, gaps, what was assumed)."""
        return [str(w) for w in self.data.get("warnings") or []]

    @property
    def recording(self) -> Dict[str, Any]:
        """The recording block: path, size, span, channels, data loss, metadata."""
        return dict(self.data.get("recording") or {})

    @property
    def theta_covariance(self) -> Optional[np.ndarray]:
        """The covariance of Θ = [Φ Γ] (row by row), where the method gives one."""
        c = self.data.get("theta_covariance")
        return None if c is None else _matrix(c)

    def __getattr__(self, key: str) -> Any:
        # Any other section of the report, by its key (one added after this module).
        data = self.__dict__.get("data")
        if data is not None and key in data:
            return data[key]
        raise AttributeError(f"the report has no section {key!r}")

    # --- text ---------------------------------------------------------------------------

    def to_json(self) -> str:
        """The report's JSON text, as ``heatrun replay --report`` writes it."""
        return self._text

    def save(self, path: PathLike) -> None:
        """Writes the report to ``path``, complete or not at all."""
        path = os.fspath(path)
        folder = os.path.dirname(os.path.abspath(path))
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".heatrun-", suffix=".json")
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                f.write(self._text)
            os.replace(tmp, path)
        except BaseException:
            if os.path.exists(tmp):
                os.unlink(tmp)
            raise

    def summary(self) -> str:
        """The paper-style summary, as ``heatrun replay`` prints it (a report made here:
        one read from a file keeps the model, not all the figures the summary prints)."""
        if self._summary is None:
            raise _heatrun.HeatrunError(
                f"{self._name}: a report read from a file has no summary; replay the recording"
            )
        return self._summary

    def __repr__(self) -> str:
        t = ", ".join(f"{v:.2f}" for v in self.time_constants_s)
        return f"<heatrun.Report {self.method or '?'} states={self.states} T=[{t}] s>"

    # --- traces and uses -------------------------------------------------------------------

    def traces(self) -> "Any":
        """The measured temperature, the model's and the residual per state on the
        replay's grid, as a pandas DataFrame indexed by time (UTC): columns
        ``(state, "measured")``, ``(state, "model")``, ``(state, "residual")``. The model is
        simulated from the initial state, θ̂ = θ_ref + T_base·ŷ; the residual y − ŷ is in
        K and NaN where the estimator did not compare (a screened glitch, a gap).

        Only a report made here (by :func:`replay` or :func:`identify`) has them: a report
        read from a file holds the model, not the recording's series."""
        import pandas as pd

        if self._traces is None:
            raise _heatrun.HeatrunError(
                f"{self._name}: a report read from a file has no traces; replay the recording"
            )
        t = np.frombuffer(self._traces["time_ns"], dtype="<i8")
        index = pd.DatetimeIndex(pd.to_datetime(t, unit="ns", utc=True), name="time")
        keys = []
        series = []
        for st in self._traces["states"]:
            for kind in ("measured", "model", "residual"):
                keys.append((st["name"], kind))
                series.append(np.frombuffer(st[kind], dtype="<f8"))
        columns = pd.MultiIndex.from_tuples(keys, names=["state", "trace"])
        return pd.DataFrame(np.column_stack(series) if series else None, index=index, columns=columns)

    def predict(
        self,
        load_frame: Any,
        *,
        initial: str = "measured",
        initial_temps: Optional[Sequence[float]] = None,
    ) -> "Any":
        """Every part's temperature under a load schedule, as ``heatrun predict`` gives it.

        ``load_frame``: a DataFrame (or dict of columns) with ``time_s`` (a column or the
        index) and the schedule's columns as ``heatrun predict --load`` reads them
        (``armature_current_a``, ``field_current_a``, ``line_voltage_kv``, or
        ``apparent_power_mva`` with ``power_factor``; optional ``coolant_inlet_temp_c``; a
        spec model's own input channels). Each row holds until the next.

        Returns a DataFrame indexed by ``time_s`` with ``<state>_c`` per state and, where
        the report carries the covariance of Θ, its 95 % band ``<state>_c_lo95`` and
        ``<state>_c_hi95``. ``initial``: ``"measured"`` (the recording's initial
        temperatures) or ``"steady"`` (the first row's steady state); ``initial_temps``,
        °C per state, overrides it."""
        import io

        import pandas as pd

        frame = pd.DataFrame(load_frame)
        if "time_s" not in frame.columns:
            frame = frame.reset_index()
            first = frame.columns[0]
            frame = frame.rename(columns={first: "time_s"})
        with tempfile.TemporaryDirectory(prefix="heatrun-") as folder:
            load = os.path.join(folder, "load.csv")
            frame.to_csv(load, index=False, float_format="%.17g")
            out = _heatrun.predict(
                self._text,
                self._name,
                load,
                initial=initial,
                initial_temps=None if initial_temps is None else [float(t) for t in initial_temps],
            )
        result = pd.read_csv(io.StringIO(out["csv"]), index_col="time_s")
        result.attrs["warnings"] = list(out["warnings"])
        return result

    def rating(
        self,
        insulation_class: Optional[str] = "F",
        *,
        limits: Optional[Dict[str, float]] = None,
        power_factor: Optional[float] = None,
        voltage_kv: Optional[float] = None,
        coolant_c: Optional[float] = None,
        overloads_percent: Sequence[float] = (110, 120, 130, 140, 150),
    ) -> Dict[str, Any]:
        """The machine's thermal rating, as ``heatrun rating --json`` writes it: the
        largest continuous apparent power and the part that limits it, and the time to
        the first limit at each overload (with 95 % intervals where the report carries
        the covariance of Θ). ``insulation_class``: ``"B"``, ``"F"`` or ``"H"`` (IEC
        60034-1 Table 7's limits), or None with ``limits`` alone; ``limits``: °C per state
        name, overriding the class's. The table as ``heatrun rating`` prints it is under
        the key ``"table"``."""
        text, table = _heatrun.rating(
            self._text,
            self._name,
            insulation_class=insulation_class,
            limits=[(k, float(v)) for k, v in (limits or {}).items()],
            power_factor=power_factor,
            voltage_kv=voltage_kv,
            coolant_c=coolant_c,
            overloads_percent=[float(p) for p in overloads_percent],
        )
        rated: Dict[str, Any] = json.loads(text)
        rated["table"] = table
        return rated


def load_report(path: PathLike) -> Report:
    """Reads a report written by ``heatrun replay --report`` (a path, or a URL where the
    package is built with object storage), checked against the profile."""
    name = os.fspath(path)
    return Report(_heatrun.read_report(name), name=name)

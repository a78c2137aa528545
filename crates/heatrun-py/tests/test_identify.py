"""`heatrun.identify` on a table in memory: the TCLab estimation file read with pandas
gives the model the command line gives from the same file and the example's map and spec."""

import json

import numpy as np
import pandas as pd
import pytest

import heatrun
from conftest import TCLAB, TCLAB_EXAMPLE

SPEC = TCLAB_EXAMPLE / "spec.toml"
# The heater commands are held between writes (the example's map says so).
STEP = {"Q1": "step", "Q2": "step"}
NAMES = {
    "Time (sec)": "time",
    "Heater 1 (%)": "Q1",
    "Heater 2 (%)": "Q2",
    "Temperature 1 (degC)": "T1",
    "Temperature 2 (degC)": "T2",
}


def tclab_frame(name="tclab_mimo_data.csv"):
    # Before pandas 3 the default parser may miss the nearest double by a unit in the last
    # place; the command line's reader does not.
    exact = {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}
    frame = pd.read_csv(TCLAB / name, skipinitialspace=True, **exact)
    frame = frame.rename(columns=NAMES).set_index("time")
    return frame


@pytest.fixture(scope="module")
def tclab_report():
    return heatrun.identify(tclab_frame(), spec=SPEC, interpolation=STEP)


def test_the_model_equals_the_command_lines_to_the_digit(tclab_report, cli, tmp_path):
    cli("import", TCLAB / "tclab_mimo_data.csv", "--map", TCLAB_EXAMPLE / "map.toml", "--out", tmp_path / "t.mcap")
    cli("replay", tmp_path / "t.mcap", "--spec", SPEC, "--report", tmp_path / "r.json", "--rrd", tmp_path / "r.rrd", "-q")
    theirs = json.loads((tmp_path / "r.json").read_text())
    ours = tclab_report.data
    for key in ("phi", "gamma", "a_c", "b_c", "time_constants_s", "fit", "steady_state", "uncertainty", "network"):
        assert ours[key] == theirs[key], key


def test_the_model_is_the_data_sets(tclab_report):
    r = tclab_report
    assert r.states == ["T1", "T2"] and r.inputs == ["heater_1_power", "heater_2_power"]
    # Two real time constants of a few minutes (a heater block each), Φ's own, and a fit
    # of the estimation file above 90 % per thermistor.
    eig = np.sort(np.linalg.eigvals(r.phi).real)
    np.testing.assert_allclose(np.sort(r.time_constants_s), np.sort(-1.0 / np.log(eig)), rtol=1e-9)
    assert all(60 < t < 600 for t in r.time_constants_s)
    assert min(r.fit.nrmse_fit_percent) > 90
    traces = r.traces()
    assert traces[("T1", "measured")].iloc[0] == pytest.approx(20.83)
    assert len(traces) == 600


def test_a_dict_of_arrays_gives_the_same_model(tclab_report):
    frame = tclab_frame()
    data = {"time": frame.index.to_numpy(), **{c: frame[c].to_numpy() for c in frame.columns}}
    r = heatrun.identify(data, spec=SPEC, interpolation=STEP)
    assert r.data["phi"] == tclab_report.data["phi"]
    assert r.data["gamma"] == tclab_report.data["gamma"]


def test_datetimes_give_the_same_model(tclab_report):
    frame = tclab_frame()
    frame.index = pd.Timestamp("2024-03-01T12:00:00Z") + pd.to_timedelta(frame.index, unit="s")
    r = heatrun.identify(frame, spec=SPEC, interpolation=STEP)
    np.testing.assert_allclose(r.phi, tclab_report.phi, rtol=1e-9)
    assert r.traces().index[0] == pd.Timestamp("2024-03-01T12:00:00Z")


def test_a_validation_frame_gives_the_validation_fit(tclab_report):
    r = heatrun.identify(tclab_frame(), spec=SPEC, interpolation=STEP, validate=tclab_frame("tclab_mimo_step_data_3s.csv").rename(
        columns={"Heater 1": "Q1", "Heater 2": "Q2", "Temperature 1": "T1", "Temperature 2": "T2"}
    ))
    assert r.data["phi"] == tclab_report.data["phi"]
    fit = r.validation["fit"].nrmse_fit_percent
    # On the other file, simulated from its start: above 75 % per thermistor.
    assert len(fit) == 2 and min(fit) > 75
    assert "validation" in r.validation["source"]


def test_a_missing_column_is_bad_input_naming_it():
    frame = tclab_frame().drop(columns=["Q2"])
    with pytest.raises(heatrun.BadInputError, match="'Q2'"):
        heatrun.identify(frame, spec=SPEC)


def test_an_index_that_is_no_time_is_bad_input():
    frame = tclab_frame()
    frame.index = [f"row {i}" for i in range(len(frame))]
    with pytest.raises(heatrun.BadInputError, match="index"):
        heatrun.identify(frame, spec=SPEC)


def test_a_backward_time_is_the_imports_error_naming_the_row():
    frame = tclab_frame()
    index = frame.index.to_numpy().copy()
    index[5] = index[2]
    frame.index = index
    with pytest.raises(heatrun.BadInputError, match=r"the frame's row 5 \(from 0\).*time goes backwards"):
        heatrun.identify(frame, spec=SPEC)

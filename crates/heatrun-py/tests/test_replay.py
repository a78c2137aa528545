"""`heatrun.replay` on the shipped fixture: the paper's model, the report's JSON and
typed attributes, the traces, the errors, and the GIL released while it works."""

import json
import math
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import heatrun
from conftest import FIXTURE, ROOT, TRUTH


def test_the_fixture_gives_the_papers_time_constants(fixture_report):
    truth = json.loads(TRUTH.read_text())
    # Eq. 26 from the paper's Φ: 23.90 s, 737.21 s, 3305.73 s (the library's doctest's
    # tolerance: the fixture is noisy, the estimate within 0.01 s of the slower ones).
    got = fixture_report.time_constants_s
    assert len(got) == 3
    assert abs(got[1] - truth["time_constants_s"][1]) < 0.01
    assert abs(got[2] - truth["time_constants_s"][2]) < 1.0
    assert abs(got[0] - truth["time_constants_s"][0]) < 0.1


def test_the_time_constants_are_phis_eigenvalues(fixture_report):
    # An independent computation: T_i = −Ts / ln λ_i(Φ), from the report's Φ by numpy.
    r = fixture_report
    eig = np.sort(np.linalg.eigvals(r.phi).real)
    expected = np.sort(-r.sample_time_s / np.log(eig))
    assert np.allclose(np.sort(r.time_constants_s), expected, rtol=1e-9)
    assert r.phi.shape == (3, 3) and r.gamma.shape == (3, 3)
    assert r.a_c.shape == (3, 3) and r.b_c.shape == (3, 3)


def test_the_one_liner_prints_the_reports_figures():
    # The acceptance's command, in a fresh interpreter from the repository's root.
    out = subprocess.run(
        [sys.executable, "-c", "import heatrun; print(heatrun.replay('fixtures/paper_heat_run.mcap').time_constants_s)"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    printed = json.loads(out)
    report = heatrun.replay(str(FIXTURE), traces=False)
    assert printed == report.data["time_constants_s"]


def test_the_reports_json_equals_the_command_lines(cli, tmp_path):
    cli("replay", FIXTURE, "--report", tmp_path / "cli.json", "--rrd", tmp_path / "cli.rrd", "-q")
    theirs = json.loads((tmp_path / "cli.json").read_text())
    ours = heatrun.replay(str(FIXTURE), traces=False).data
    for d in (theirs, ours):
        d.pop("heatrun_version")
        d["recording"].pop("path")
    assert ours == theirs


def test_the_time_constants_printed_by_the_command_line(cli, tmp_path):
    out = cli("replay", FIXTURE, "--summary", "json", "--rrd", tmp_path / "x.rrd").stdout
    assert heatrun.replay(str(FIXTURE), traces=False).time_constants_s == json.loads(out)["time_constants_s"]


def test_typed_attributes_are_views_of_the_json(fixture_report):
    r = fixture_report
    d = r.data
    assert r.states == d["states"] and r.inputs == d["inputs"]
    assert r.method == d["method"]
    np.testing.assert_array_equal(r.phi, np.array(d["phi"]))
    tcs = r.time_constants
    assert [t.value_s for t in tcs] == d["time_constants_s"]
    assert [t.part for t in tcs] == [a["part"] for a in d["assignment"]]
    ci = d["uncertainty"]["time_constants_ci95_s"]
    for t, half in zip(tcs, ci):
        lo, hi = t.interval_s
        assert lo == t.value_s - half and hi == t.value_s + half and lo < t.value_s < hi
    assert r.fit.nrmse_fit_percent == d["fit"]["nrmse_fit_percent"]
    assert r.steady_state.temperature_c == d["steady_state"]["temperature_c"]
    assert r.network is not None and r.network.data == d["network"]
    assert r.warnings == d["warnings"]
    # A section the typed view does not name is still an attribute, by its key.
    assert r.residuals == d["residuals"]
    with pytest.raises(AttributeError):
        r.no_such_section
    assert json.loads(r.to_json()) == d


def test_the_steady_state_solves_the_model(fixture_report):
    # x_ss = (I − Φ)⁻¹ Γ u: the report's steady rise from its own Φ, Γ and input (pu).
    r = fixture_report
    u = np.array(r.steady_state.input_pu)
    x = np.linalg.solve(np.eye(3) - r.phi, r.gamma @ u)
    base = r.data["estimation"]["temperature_base_k"]
    np.testing.assert_allclose(x * base, r.steady_state.rise_k, rtol=1e-6)


def test_traces_are_measured_model_and_their_difference(fixture_report):
    frame = fixture_report.traces()
    states = fixture_report.states
    assert list(frame.columns.get_level_values(0).unique()) == states
    assert str(frame.index.tz) == "UTC"
    for s in states:
        m, y, r = frame[(s, "measured")], frame[(s, "model")], frame[(s, "residual")]
        both = r.notna()
        assert both.mean() > 0.99
        # residual = y − ŷ in K (the rise's unit is the temperature's step).
        np.testing.assert_allclose(r[both], (m - y)[both], atol=1e-9)
    # Its RMS over the compared instants is the report's RMSE per state.
    rms = [math.sqrt(float((frame[(s, "residual")].dropna() ** 2).mean())) for s in states]
    np.testing.assert_allclose(rms, fixture_report.fit.rmse_k, rtol=1e-6)


def test_a_report_round_trips_through_a_file(fixture_report, tmp_path):
    path = tmp_path / "r.json"
    fixture_report.save(path)
    back = heatrun.load_report(path)
    assert back.to_json() == fixture_report.to_json()
    assert back.time_constants_s == fixture_report.time_constants_s
    np.testing.assert_array_equal(back.phi, fixture_report.phi)
    assert "heat run" in fixture_report.summary()
    with pytest.raises(heatrun.HeatrunError, match="no summary"):
        back.summary()
    with pytest.raises(heatrun.HeatrunError, match="no traces"):
        back.traces()


def test_a_missing_recording_is_bad_input_naming_it(tmp_path):
    missing = tmp_path / "absent.mcap"
    with pytest.raises(heatrun.BadInputError) as e:
        heatrun.replay(missing)
    assert str(missing) in str(e.value)
    assert "\n" not in str(e.value)
    assert isinstance(e.value, heatrun.HeatrunError)


def test_a_file_that_is_no_recording_is_bad_input(tmp_path):
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"not an mcap file at all")
    with pytest.raises(heatrun.BadInputError, match="bad.mcap"):
        heatrun.replay(bad)


def test_bad_options_are_refused_before_reading(tmp_path):
    with pytest.raises(heatrun.BadInputError, match="method"):
        heatrun.replay(FIXTURE, method="magic")
    with pytest.raises(heatrun.BadInputError, match="reference"):
        heatrun.replay(FIXTURE, reference="ambient")
    with pytest.raises(heatrun.BadInputError, match="field_state"):
        heatrun.replay(FIXTURE, field_state=True, spec=ROOT / "examples" / "tclab_mimo_heaters" / "spec.toml")
    with pytest.raises(heatrun.BadInputError, match="held-out fraction"):
        heatrun.replay(FIXTURE, holdout=1.5)


def test_a_report_that_is_none_is_bad_input(tmp_path):
    p = tmp_path / "r.json"
    p.write_text('{"profile": "something else"}')
    with pytest.raises(heatrun.BadInputError, match="r.json"):
        heatrun.load_report(p)


def test_the_gil_is_released_while_the_library_works():
    # While replays run in one thread, this one keeps running Python: the longest pause
    # between its steps is a small part of one replay (with the GIL held it would be all of
    # it). Judged against the replays' own durations, not a fixed time: a faster library
    # must not make the test vacuous or fail it (the fixture's replay took 0.19 s here).
    durations = []

    def work():
        for _ in range(3):
            began = time.perf_counter()
            heatrun.replay(str(FIXTURE), traces=False)
            durations.append(time.perf_counter() - began)

    t = threading.Thread(target=work)
    t.start()
    last, longest = time.perf_counter(), 0.0
    while t.is_alive():
        now = time.perf_counter()
        longest = max(longest, now - last)
        last = now
    t.join()
    assert len(durations) == 3
    assert longest < 0.25 * min(durations), (longest, durations)


def test_threads_replay_alike():
    # Two threads at once give what one gives alone (no state shared between replays).
    results = [None, None]

    def run(i):
        results[i] = heatrun.replay(str(FIXTURE), traces=False).to_json()

    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results[0] == results[1] == heatrun.replay(str(FIXTURE), traces=False).to_json()


def test_a_report_pickles_whole(fixture_report):
    # What a Dask or Ray task returns travels pickled: the report, its summary and traces.
    import pickle

    back = pickle.loads(pickle.dumps(fixture_report))
    assert back.to_json() == fixture_report.to_json()
    assert back.summary() == fixture_report.summary()
    assert back.traces().equals(fixture_report.traces())

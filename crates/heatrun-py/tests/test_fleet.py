"""Fleets from Python: reports gathered (from threads, or a local Dask cluster's worker
processes) reduced into `heatrun fleet summary`'s table and compared."""

import importlib.util
import io
import json
import os
import shutil
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pandas as pd
import pytest

import heatrun
from conftest import FIXTURE, ROOT

# Four: the least a fleet comparison takes.
UNITS = 4


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    """A folder of four recordings (copies of the fixture, as four units' files) and
    their reports, replayed on four threads at once."""
    folder = tmp_path_factory.mktemp("fleet") / "runs"
    folder.mkdir()
    for u in range(1, UNITS + 1):
        shutil.copy(FIXTURE, folder / f"u{u}.mcap")
    paths = heatrun.list_recordings(str(folder))
    with ThreadPoolExecutor(UNITS) as pool:
        reports = list(pool.map(lambda p: heatrun.replay(p, traces=False), paths))
    return folder, paths, reports


def test_the_folder_is_listed_in_order(fleet):
    folder, paths, _ = fleet
    assert paths == [os.path.join(str(folder), f"u{u}.mcap") for u in range(1, UNITS + 1)]


def test_the_table_holds_each_reports_figures(fleet):
    _, paths, reports = fleet
    table = heatrun.fleet_summary(reports)
    assert list(table["recording"]) == paths
    assert list(table["status"]) == ["ok"] * UNITS
    assert list(table.columns[:5]) == ["recording", "status", "t1_s", "t2_s", "t3_s"]
    for row, report in zip(table.itertuples(index=False), reports):
        d = report.data
        # The reduction reads each report's JSON back as `heatrun fleet summary` does
        # (serde_json's parser, within a unit in the last place of the nearest double).
        same = dict(rtol=5e-16, atol=0)
        np.testing.assert_allclose([row.t1_s, row.t2_s, row.t3_s], d["time_constants_s"], **same)
        np.testing.assert_allclose(
            [row.fit_stator_pct, row.fit_core_pct, row.fit_water_pct], d["fit"]["nrmse_fit_percent"], **same
        )
        np.testing.assert_allclose(
            [row.steady_stator_c, row.steady_core_c, row.steady_water_c], d["steady_state"]["temperature_c"], **same
        )
    # Reports as JSON texts or files reduce alike.
    assert heatrun.fleet_summary([r.to_json() for r in reports]).attrs["csv"] == table.attrs["csv"]


def test_an_unreadable_report_is_a_failed_row(fleet, tmp_path):
    _, _, reports = fleet
    bad = tmp_path / "bad.report.json"
    bad.write_text("{}")
    table = heatrun.fleet_summary([reports[0], bad])
    assert table["status"].iloc[1].startswith("failed: ")
    with pytest.raises(heatrun.BadInputError):
        heatrun.fleet_summary([bad])


def test_the_table_equals_the_command_lines(fleet, cli, tmp_path):
    folder, _, reports = fleet
    cli("replay", folder, "--out-dir", tmp_path / "res", "--jobs", "2", "-q")
    cli("fleet", "summary", tmp_path / "res", "--csv", tmp_path / "fleet.csv")
    assert heatrun.fleet_summary(reports).attrs["csv"] == (tmp_path / "fleet.csv").read_text()


def test_identical_units_are_no_outliers(fleet):
    _, paths, reports = fleet
    comparison = heatrun.fleet_compare(reports, labels=[f"u{u}" for u in range(1, UNITS + 1)])
    assert comparison["reports"] == [f"u{u}" for u in range(1, UNITS + 1)]
    assert comparison["outliers"] == []
    scores = comparison["scores"]
    assert set(scores["report"]) == set(comparison["reports"])
    assert (scores["outlier"] == False).all()  # noqa: E712
    assert "u1" in comparison["summary"]


def test_a_dask_cluster_gives_the_same_table(fleet):
    pytest.importorskip("dask")
    pytest.importorskip("distributed")
    spec = importlib.util.spec_from_file_location("fleet_dask", ROOT / "crates" / "heatrun-py" / "examples" / "fleet_dask.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    _, paths, reports = fleet
    results, _ = example.replay_fleet(paths, 2)
    assert [s for s, _ in results] == ["ok"] * UNITS
    gathered = heatrun.fleet_summary([text for _, text in results])
    assert gathered.attrs["csv"] == heatrun.fleet_summary(reports).attrs["csv"]


def test_a_unit_whose_slowest_time_constant_differs_is_named(fleet):
    # One unit's report doctored: its slowest time constant half as long again, which
    # no spread of four identical units and no interval of its own covers.
    _, _, reports = fleet
    texts = [r.to_json() for r in reports]
    odd = json.loads(texts[2])
    odd["time_constants_s"][2] *= 1.5
    texts[2] = json.dumps(odd)
    labels = [f"u{u}" for u in range(1, UNITS + 1)]
    comparison = heatrun.fleet_compare(texts, labels=labels)
    named = {o["report"] for o in comparison["outliers"]}
    assert named == {"u3"}
    assert any(o["quantity"].startswith("time_constant") for o in comparison["outliers"])


def test_a_report_that_is_none_is_named_by_its_label(fleet):
    _, _, reports = fleet
    texts = [r.to_json() for r in reports] + ['{"profile": "other"}']
    with pytest.raises(heatrun.BadInputError, match="unit-x"):
        heatrun.fleet_compare(texts, labels=["a", "b", "c", "d", "unit-x"])

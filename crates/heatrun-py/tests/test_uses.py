"""The uses of the model from Python: `Report.predict` and `Report.rating`, over the
fixture's model, against the IEC limits and the model's own steady state."""

import numpy as np
import pandas as pd
import pytest

import heatrun

DAY = pd.DataFrame(
    {
        "time_s": [0, 21600, 43200, 46800, 86400],
        "apparent_power_mva": [60, 100, 115, 80, 80],
        "power_factor": [0.9] * 5,
    }
)


def test_a_day_is_predicted_with_its_bands(fixture_report):
    pred = fixture_report.predict(DAY)
    states = fixture_report.states
    assert pred.index.name == "time_s"
    assert pred.index[0] == 0 and pred.index[-1] == 86400
    assert len(pred) == 86401  # every Ts = 1 s
    for s in states:
        value, lo, hi = pred[f"{s}_c"], pred[f"{s}_c_lo95"], pred[f"{s}_c_hi95"]
        assert (lo <= value + 1e-9).all() and (value <= hi + 1e-9).all()
    # It starts from the recording's initial temperatures (the measured start).
    start = fixture_report.data["estimation"]["initial_temperature_c"]
    np.testing.assert_allclose(pred.iloc[0][[f"{s}_c" for s in states]], start, atol=5e-4)
    # The overload hour (115 MVA from 43200 s to 46800 s) is the day's peak.
    assert 43200 < pred[f"{states[0]}_c"].idxmax() <= 46800 + 600


def test_a_steady_start_under_a_constant_load_stays_put(fixture_report):
    # The steady state of the first row is a fixed point of x(k+1) = Φ x(k) + Γ u(k).
    flat = pd.DataFrame({"time_s": [0, 20000], "apparent_power_mva": [90, 90], "power_factor": [0.9, 0.9]})
    pred = fixture_report.predict(flat, initial="steady")
    for s in fixture_report.states:
        col = pred[f"{s}_c"]
        assert col.max() - col.min() < 2e-4, s  # the CSV's 4 decimals


def test_a_bad_schedule_is_bad_input(fixture_report):
    with pytest.raises(heatrun.BadInputError):
        fixture_report.predict(pd.DataFrame({"time_s": [0, 10], "nonsense": [1, 2]}))
    with pytest.raises(heatrun.BadInputError, match="initial"):
        fixture_report.predict(DAY, initial="warm")


def test_the_rating_holds_the_parts_to_iec_limits(fixture_report):
    rated = fixture_report.rating("F")
    limits = {p["name"]: p["limit_c"] for p in rated["limits"]}
    # IEC 60034-1 Table 7, class F over 40 °C: windings by ETD 110 K, the field by
    # resistance 105 K, the core held to the stator's.
    assert limits["stator_winding_temp"] == 150.0
    assert limits["core_temp"] == 150.0
    assert limits["field_winding_temp"] == 145.0
    # At the largest continuous power, the limiting part is at its limit, no part above.
    at_max = dict(zip([p["name"] for p in rated["limits"]], rated["temperatures_at_max_c"]))
    assert at_max[rated["limiting_state"]] == pytest.approx(limits[rated["limiting_state"]], abs=0.05)
    assert all(at_max[n] <= limits[n] + 0.05 for n in limits)
    assert "continuous rating" in rated["table"]
    # A lower class rates the machine lower; a higher one higher.
    b = fixture_report.rating("B")["max_continuous_apparent_power_mva"]
    h = fixture_report.rating("H")["max_continuous_apparent_power_mva"]
    assert b < rated["max_continuous_apparent_power_mva"] < h
    np.testing.assert_allclose([o["current_percent"] for o in rated["overloads"]], [110, 120, 130, 140, 150])


def test_a_limit_overrides_the_class(fixture_report):
    rated = fixture_report.rating("F", limits={"core_temp": 60.0})
    limits = {p["name"]: p["limit_c"] for p in rated["limits"]}
    assert limits["core_temp"] == 60.0
    with pytest.raises(heatrun.BadInputError, match="insulation_class"):
        fixture_report.rating("Z")

"""Sensor conversions through :func:`models.sensors.to_force`, the entry point: each calibration,
bad data and arguments named by their field, the plan-file format (mapping round trips, dotted
field names) and every public function citing its paper.
"""

from __future__ import annotations

import json
import math
import re
import tomllib

import numpy as np
import pytest
from numpy.testing import assert_allclose
from sensors_support import IDLE_TABLE, TAI_A, TAI_B, TAI_K1, _kim_jeon_150_mpm_data, _tai_tests

from models import sensors
from models.errors import InputError
from models.sensors import (
    IVESTER_SPINDLE_LOAD,
    KIM_JEON_SPINDLE_FMAX_4500RPM,
    Converted,
    FeedDependentCurrentCalibration,
    IvesterSpindleLoadCalibration,
    LinearCurrentCalibration,
    TaiCurrentFeedCalibration,
    calibration_from_mapping,
    calibration_to_mapping,
    calibrations_from_mapping,
    fit_linear_calibration,
    fit_tai_calibration,
    ivester_force_N,
    kim_jeon_rms_current_A,
    linear_current_force_N,
    tai_feed_rate_mm_min,
    tai_reference_current_A,
    to_force,
)

# --------------------------------------------------------------------------------------------
# to_force: the entry point, and bad data


def test_to_force_with_a_linear_current_calibration():
    cal = LinearCurrentCalibration(
        offset_N=-556.4, slope_N_per_A=173.55, u_offset_N=4.0, u_slope_N_per_A=1.0,
        corr_offset_slope=-0.9, residual_sd_N=3.0, source="test",
    )  # fmt: skip
    force = to_force(cal, "spindle_current_A", 4.5, 0.02, {})
    standard = linear_current_force_N(cal, 4.5, 0.01)
    assert_allclose(force.value, -556.4 + 173.55 * 4.5)
    assert_allclose(force.uncertainty, 2 * standard.uncertainty)
    assert isinstance(force, Converted)


@pytest.mark.parametrize(
    ("calibration", "raw", "value", "uncertainty", "context", "field"),
    [
        (IDLE_TABLE, "spindle_load_V", 0.8, 0.01, {"workpiece_diameter_mm": 60},
         "context.spindle_speed_rpm"),
        (IDLE_TABLE, "spindle_load_V", 0.8, 0.01, {"spindle_speed_rpm": 900},
         "context.workpiece_diameter_mm"),
        (IVESTER_SPINDLE_LOAD, "spindle_load_V", 0.8, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "context.idle_load_V"),
        (IDLE_TABLE, "spindle_load_V", 0.8, 0.01,
         {"spindle_speed_rpm": "fast", "workpiece_diameter_mm": 60}, "context.spindle_speed_rpm"),
        (IDLE_TABLE, "spindle_load_V", 0.8, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": -60}, "context.workpiece_diameter_mm"),
        (IDLE_TABLE, "spindle_load_V", 0.8, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": math.nan},
         "context.workpiece_diameter_mm"),
        (IDLE_TABLE, "spindle_load_V", 0.8, 0.01,
         {"spindle_speed_rpm": 9000, "workpiece_diameter_mm": 60}, "context.spindle_speed_rpm"),
        (IDLE_TABLE, "spindle_load_V", math.nan, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "spindle_load_V.value"),
        (IDLE_TABLE, "spindle_load_V", "0.8", 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "spindle_load_V.value"),
        (IDLE_TABLE, "spindle_load_V", -0.8, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "spindle_load_V.value"),
        (IDLE_TABLE, "spindle_load_V", 0.1, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "spindle_load_V.value"),
        (IDLE_TABLE, "spindle_load_V", 0.8, -0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "spindle_load_V.uncertainty"),
        (IDLE_TABLE, "spindle_current_A", 0.8, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "raw_quantity"),
        (IDLE_TABLE, "spindle_power_kW", 0.8, 0.01, {}, "raw_quantity"),
        (KIM_JEON_SPINDLE_FMAX_4500RPM, "spindle_current_A", 4.5, 0.01,
         {"spindle_speed_rpm": 4500}, "context.feed_rate_mm_min"),
        (KIM_JEON_SPINDLE_FMAX_4500RPM, "spindle_current_A", 4.5, 0.01,
         {"feed_rate_mm_min": 300}, "context.spindle_speed_rpm"),
        (KIM_JEON_SPINDLE_FMAX_4500RPM, "spindle_current_A", 4.5, 0.01,
         {"spindle_speed_rpm": 3000, "feed_rate_mm_min": 300}, "context.spindle_speed_rpm"),
        (KIM_JEON_SPINDLE_FMAX_4500RPM, "spindle_current_A", 4.5, 0.01,
         {"spindle_speed_rpm": 4500, "feed_rate_mm_min": 600}, "context.feed_rate_mm_min"),
        (TaiCurrentFeedCalibration(TAI_A, TAI_B, TAI_K1), "spindle_current_A", 0.2, 0.0, {},
         "calibration.kind"),
        (object(), "spindle_current_A", 0.2, 0.0, {}, "calibration.kind"),
    ],
)  # fmt: skip
def test_to_force_bad_data_names_the_field(calibration, raw, value, uncertainty, context, field):
    with pytest.raises(InputError) as err:
        to_force(calibration, raw, value, uncertainty, context)
    assert err.value.field == field


def test_to_force_path_names_the_reading():
    with pytest.raises(InputError) as err:
        to_force(IDLE_TABLE, "spindle_load_V", math.inf, 0.01,
                 {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60},
                 path="operations[0].measurements.spindle_load_V")  # fmt: skip
    assert err.value.field == "operations[0].measurements.spindle_load_V.value"


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: ivester_force_N(True, 0.0, 600, 60, idle_load_V=0.3), "load_V"),
        (lambda: ivester_force_N(0.8, 0.0, 0, 60, idle_load_V=0.3), "spindle_speed_rpm"),
        (lambda: ivester_force_N(0.8, 0.0, 600, None, idle_load_V=0.3), "workpiece_diameter_mm"),
        (lambda: ivester_force_N(0.8, math.nan, 600, 60, idle_load_V=0.3), "u_load_V"),
        (lambda: kim_jeon_rms_current_A([1.0, 2.0]), "phase_currents_A"),
        (lambda: kim_jeon_rms_current_A([1.0, "2", 3.0]), "phase_currents_A[1]"),
        (lambda: kim_jeon_rms_current_A([1.0, 2.0, 3.0], [0.1, -0.1, 0.1]),
         "u_phase_currents_A[1]"),
        (lambda: fit_linear_calibration([1.0, 2.0], [10.0, 20.0]), "currents_A"),
        (lambda: fit_linear_calibration([1.0, 1.0, 1.0], [10.0, 20.0, 30.0]), "currents_A"),
        (lambda: fit_linear_calibration([1.0, 2.0, 3.0], [10.0, 20.0]), "forces_N"),
        (lambda: fit_linear_calibration([1.0, math.nan, 3.0], [1.0, 2.0, 3.0]), "currents_A[1]"),
        (lambda: fit_linear_calibration([1.0, 2.0, 3.0], [1.0, -2.0, 3.0]), "forces_N[1]"),
        (lambda: fit_linear_calibration(3.0, [1.0, 2.0, 3.0]), "currents_A"),
        (lambda: fit_linear_calibration([1.0, 2.0, 3.0], [30.0, 20.0, 10.0]), "forces_N"),
        (lambda: LinearCurrentCalibration(0.0, -1.0), "slope_N_per_A"),
        (lambda: LinearCurrentCalibration(0.0, 1.0, corr_offset_slope=1.5), "corr_offset_slope"),
        (lambda: tai_feed_rate_mm_min(TaiCurrentFeedCalibration(0.1, 1e-4), 0.05), "current_A"),
        (lambda: TaiCurrentFeedCalibration(0.1, 1e-4, 0.2, corr_idle_slope=0.9,
                                           corr_idle_wear=0.9, corr_slope_wear=-0.9),
         "corr_idle_slope"),
        (lambda: tai_reference_current_A(0.28, 1.17), "factor"),
        (lambda: IvesterSpindleLoadCalibration(idle_speeds_rpm=(600.0, 300.0),
                                               idle_loads_V=(0.2, 0.3)), "idle_speeds_rpm"),
        (lambda: IvesterSpindleLoadCalibration(idle_speeds_rpm=(300.0, 600.0),
                                               idle_loads_V=(0.2,)), "idle_loads_V"),
        (lambda: FeedDependentCurrentCalibration(points=(LinearCurrentCalibration(0, 1),)),
         "points"),
        (lambda: FeedDependentCurrentCalibration(
            points=(LinearCurrentCalibration(0, 1), LinearCurrentCalibration(0, 2))),
         "points[0].feed_rate_mm_min"),
    ],
)  # fmt: skip
def test_bad_arguments_name_the_field(call, field):
    with pytest.raises(InputError) as err:
        call()
    assert err.value.field == field


# --------------------------------------------------------------------------------------------
# plan-file format


def _docstring_toml():
    """The TOML example of the module docstring, so that the documentation stays true."""
    doc = sensors.__doc__
    block = doc[doc.index("::\n") + 3 : doc.index("Read them with")]
    return tomllib.loads("\n".join(line[4:] for line in block.splitlines()))


def test_docstring_example_reads():
    plan = _docstring_toml()
    cals = calibrations_from_mapping(plan["machine"]["calibrations"], "machine.calibrations")
    load = cals["spindle_load"]
    assert isinstance(load, IvesterSpindleLoadCalibration)
    assert load.idle_speeds_rpm == (300.0, 600.0, 1200.0, 2400.0)
    assert load.m_low_N_mm_per_V == 2.19e5
    assert isinstance(cals["spindle_current"], LinearCurrentCalibration)
    assert cals["spindle_current"].spindle_speed_rpm == 4500
    by_feed = cals["spindle_current_by_feed"]
    assert isinstance(by_feed, FeedDependentCurrentCalibration)
    assert by_feed.feed_rates_mm_min == (150.0, 300.0)
    assert isinstance(cals["milling_current"], TaiCurrentFeedCalibration)
    force, u_force = to_force(
        load, "spindle_load_V", 0.9, 0.02, {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}
    )
    assert force > 0 and u_force > 0


def test_defaults_of_a_minimal_spindle_load_table_are_the_papers():
    cal = calibration_from_mapping(
        {"kind": "ivester_spindle_load", "source": "paper"}, "machine.calibrations.load"
    )
    assert cal == IvesterSpindleLoadCalibration(source="paper")
    assert (cal.m_low_N_mm_per_V, cal.m_coefficient, cal.m_exponent) == (2.19e5, 1.39e8, -1.52)
    assert cal.corner_speed_rad_s == 70.2


@pytest.mark.parametrize(
    "calibration",
    [
        IVESTER_SPINDLE_LOAD,
        IDLE_TABLE,
        KIM_JEON_SPINDLE_FMAX_4500RPM,
        fit_linear_calibration(*_kim_jeon_150_mpm_data(), date="2024-05-02", notes="cuts 1-15"),
        fit_tai_calibration(*_tai_tests(noise_A=0.002), source="test"),
    ],
)
def test_mapping_round_trip(calibration):
    table = calibration_to_mapping(calibration)
    assert calibration_from_mapping(table, "c") == calibration
    assert calibration_from_mapping(json.loads(json.dumps(table)), "c") == calibration


def test_numpy_scalars_are_stored_as_plain_floats():
    cal = LinearCurrentCalibration(np.int64(-500), np.float32(170.0), n=3, source="test")
    assert type(cal.offset_N) is float and type(cal.slope_N_per_A) is float
    json.dumps(calibration_to_mapping(cal))


def test_toml_date_is_read_as_iso_text():
    data = tomllib.loads(
        'kind = "linear_current"\nsource = "s"\ndate = 2024-05-02\n'
        "offset_N = -556.4\nslope_N_per_A = 173.55\n"
    )
    assert calibration_from_mapping(data, "c").date == "2024-05-02"


P = "machine.calibrations.x"


@pytest.mark.parametrize(
    ("table", "field"),
    [
        ({"source": "s"}, f"{P}.kind"),
        ({"kind": "kistler_dynamometer", "source": "s"}, f"{P}.kind"),
        ({"kind": 3, "source": "s"}, f"{P}.kind"),
        ({"kind": "ivester_spindle_load"}, f"{P}.source"),
        ({"kind": "ivester_spindle_load", "source": ""}, f"{P}.source"),
        ({"kind": "ivester_spindle_load", "source": "s", "m_exponent": "x"}, f"{P}.m_exponent"),
        ({"kind": "ivester_spindle_load", "source": "s", "m_low_N_mm_per_V": -1},
         f"{P}.m_low_N_mm_per_V"),
        ({"kind": "ivester_spindle_load", "source": "s", "u_m_N_mm_per_V": math.nan},
         f"{P}.u_m_N_mm_per_V"),
        ({"kind": "ivester_spindle_load", "source": "s", "m_slope": 1}, f"{P}.m_slope"),
        ({"kind": "ivester_spindle_load", "source": "s", "idle_speeds_rpm": [1, 2]},
         f"{P}.idle_loads_V"),
        ({"kind": "ivester_spindle_load", "source": "s", "idle_speeds_rpm": [1, 2],
          "idle_loads_V": [0.1, "x"]}, f"{P}.idle_loads_V[1]"),
        ({"kind": "ivester_spindle_load", "source": "s", "idle_speeds_rpm": [1, 2],
          "idle_loads_V": [0.1, -0.2]}, f"{P}.idle_loads_V[1]"),
        ({"kind": "linear_current", "source": "s", "slope_N_per_A": 1}, f"{P}.offset_N"),
        ({"kind": "linear_current", "source": "s", "offset_N": 1}, f"{P}.slope_N_per_A"),
        ({"kind": "linear_current", "source": "s", "offset_N": 1, "slope_N_per_A": 0},
         f"{P}.slope_N_per_A"),
        ({"kind": "linear_current", "source": "s", "offset_N": 1, "slope_N_per_A": 1,
          "u_offset_N": -1}, f"{P}.u_offset_N"),
        ({"kind": "linear_current", "source": "s", "offset_N": 1, "slope_N_per_A": 1,
          "n": 2.5}, f"{P}.n"),
        ({"kind": "linear_current", "source": "s", "offset_N": True, "slope_N_per_A": 1},
         f"{P}.offset_N"),
        ({"kind": "linear_current_by_feed", "source": "s"}, f"{P}.points"),
        ({"kind": "linear_current_by_feed", "source": "s", "points": {"a": 1}}, f"{P}.points"),
        ({"kind": "linear_current_by_feed", "source": "s",
          "points": [{"offset_N": 1, "slope_N_per_A": 1}]}, f"{P}.points[0].feed_rate_mm_min"),
        ({"kind": "linear_current_by_feed", "source": "s",
          "points": [{"feed_rate_mm_min": 1, "offset_N": 1, "slope_N_per_A": 1}]},
         f"{P}.points"),
        ({"kind": "linear_current_by_feed", "source": "s",
          "points": [{"feed_rate_mm_min": 1, "offset_N": 1, "slope_N_per_A": 1},
                     {"feed_rate_mm_min": 2, "offset_N": 1, "slope_N_per_A": "steep"}]},
         f"{P}.points[1].slope_N_per_A"),
        ({"kind": "tai_current_feed", "source": "s", "idle_current_A": 0.1},
         f"{P}.slope_A_per_mm_min"),
        ({"kind": "tai_current_feed", "source": "s", "idle_current_A": 0.1,
          "slope_A_per_mm_min": 1e-4, "corr_slope_wear": -2}, f"{P}.corr_slope_wear"),
        ("not a table", P),
    ],
)  # fmt: skip
def test_mapping_errors_name_the_dotted_field(table, field):
    with pytest.raises(InputError) as err:
        calibration_from_mapping(table, P)
    assert err.value.field == field


def test_every_public_function_cites_its_paper():
    cited = re.compile(r"Ivester|Kim & Jeon|Tai")
    for name in dir(sensors):
        obj = getattr(sensors, name)
        if (
            callable(obj)
            and getattr(obj, "__module__", "") == "models.sensors"
            and name.split("_")[0] in {"ivester", "kim", "tai", "fit", "linear", "feed", "to"}
            and not name.endswith("_from_mapping")
        ):
            assert cited.search(obj.__doc__ or ""), name


@pytest.mark.parametrize(
    ("value", "uncertainty", "field", "reason"),
    [
        # 1e11 V is within the ±1e12 every number has, its force (x 173.55 N/A) is not
        (1e11, 0.02, "spindle_current_A.value", "converts to a force of 1.735e+13 N"),
        (4.5, 9e10, "spindle_current_A.uncertainty", "converts to an uncertainty of 1.562e+13"),
    ],
)
def test_a_reading_whose_force_is_beyond_every_numbers_bound_is_refused(
    value, uncertainty, field, reason
):
    """Before, a spindle reading under the bound converted to a force over it and was stored
    (a reported force_N of that size is refused: one bound, read or converted)."""
    cal = LinearCurrentCalibration(
        offset_N=-556.4, slope_N_per_A=173.55, u_offset_N=4.0, u_slope_N_per_A=1.0,
        corr_offset_slope=-0.9, residual_sd_N=3.0, source="test",
    )  # fmt: skip
    with pytest.raises(InputError) as err:
        to_force(cal, "spindle_current_A", value, uncertainty, {})
    assert err.value.field == field and reason in str(err.value)
    assert "beyond 1e+12 N" in str(err.value)

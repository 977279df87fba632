"""The setpoint helpers behind setpoint_publisher and move_joint."""

import math

import pytest

from demo_nodes_py.setpoints import clamp, describe_setpoint, sine_setpoint


def test_sine_starts_at_zero_and_peaks_at_a_quarter_period():
    assert sine_setpoint(0.0, 2.0, 4.0) == 0.0
    assert math.isclose(sine_setpoint(1.0, 2.0, 4.0), 2.0)
    assert math.isclose(sine_setpoint(3.0, 2.0, 4.0), -2.0)


def test_sine_rejects_a_period_that_is_not_positive():
    with pytest.raises(ValueError, match='period'):
        sine_setpoint(1.0, 1.0, 0.0)


@pytest.mark.parametrize(('value', 'expected'), [(0.4, 0.4), (2.0, 1.5), (-7.0, -1.5)])
def test_clamp_keeps_setpoints_within_the_limit(value, expected):
    assert clamp(value, 1.5) == expected


def test_the_logged_line_names_the_joint_and_the_value():
    assert describe_setpoint('right_e0', 0.25) == 'right_e0 <- +0.250 rad'

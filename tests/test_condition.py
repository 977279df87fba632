"""REP 149 conditions evaluate like catkin_pkg's, and malformed ones are errors."""

from __future__ import annotations

import pytest

from wsbuild.workspace.condition import DEFAULT_VARIABLES, check_condition, evaluate_condition
from wsbuild.errors import ConditionError, ManifestError

ENV = {"ROS_VERSION": "2", "ROS_DISTRO": "jazzy", "NUM": "10", "EMPTY": ""}


@pytest.mark.parametrize(
    ("expr", "expected"),
    [
        ("$ROS_VERSION == 2", True),
        ("$ROS_VERSION == 1", False),
        ("$ROS_VERSION != 1", True),
        ("$ROS_VERSION==2", True),  # whitespace is optional
        ("  $ROS_VERSION   ==   2  ", True),
        ("2 == $ROS_VERSION", True),  # variables may be on either side
        ("$ROS_DISTRO == jazzy", True),
        ("$ROS_DISTRO == 'jazzy'", True),
        ('$ROS_DISTRO == "jazzy"', True),
        ("$ROS_DISTRO >= humble", True),
        ("$ROS_DISTRO > kilted", False),
        ("$ROS_DISTRO < kilted", True),
        ("$ROS_DISTRO <= jazzy", True),
        # Strings, never numbers: "10" sorts before "9".
        ("$NUM < 9", True),
        ("$NUM > 9", False),
        ("$NUM >= 10", True),
        ("$NUM <= 1", False),
        # Bare literals may contain '-' and '_'; quoted ones anything but their quote.
        ("$ROS_DISTRO != rolling-devel_x", True),
        ("'3.12' == \"3.12\"", True),
        ("'a \"quoted\" word' != \"it's\"", True),
    ],
)
def test_comparisons(expr: str, expected: bool) -> None:
    assert evaluate_condition(expr, ENV) is expected


@pytest.mark.parametrize(
    ("expr", "expected"),
    [
        ("$ROS_VERSION == 2 and $ROS_DISTRO == jazzy", True),
        ("$ROS_VERSION == 2 and $ROS_DISTRO == humble", False),
        ("$ROS_VERSION == 1 or $ROS_DISTRO == jazzy", True),
        ("$ROS_VERSION == 1 or $ROS_DISTRO == humble", False),
        # 'and' binds tighter than 'or' ...
        ("$ROS_VERSION == 2 or $ROS_VERSION == 1 and $ROS_DISTRO == humble", True),
        # ... unless parentheses say otherwise.
        ("($ROS_VERSION == 2 or $ROS_VERSION == 1) and $ROS_DISTRO == humble", False),
        ("((($ROS_VERSION == 2)))", True),
        ("($ROS_VERSION == 1 or ($ROS_DISTRO == jazzy and $NUM == 10))", True),
        ("$ROS_VERSION == 1 or $ROS_VERSION == 3 or $ROS_VERSION == 2", True),
        ("$ROS_VERSION == 2 and $NUM == 10 and $ROS_DISTRO == humble", False),
    ],
)
def test_and_or_parentheses(expr: str, expected: bool) -> None:
    assert evaluate_condition(expr, ENV) is expected


def test_ros_variables_have_defaults_when_unset_or_empty() -> None:
    assert DEFAULT_VARIABLES == {
        "ROS_VERSION": "2", "ROS_DISTRO": "jazzy", "ROS_PYTHON_VERSION": "3"}
    for env in ({}, {"ROS_VERSION": "", "ROS_DISTRO": "", "ROS_PYTHON_VERSION": ""}):
        assert evaluate_condition("$ROS_VERSION == 2", env)
        assert evaluate_condition("$ROS_DISTRO == jazzy", env)
        assert evaluate_condition("$ROS_PYTHON_VERSION == 3", env)
    # A set value wins over the default.
    assert evaluate_condition("$ROS_VERSION == 1", {"ROS_VERSION": "1"})
    assert evaluate_condition("$ROS_DISTRO == humble", {"ROS_DISTRO": "humble"})


def test_other_unset_variables_are_empty_strings() -> None:
    assert evaluate_condition("$NOT_SET_ANYWHERE == ''", {})
    assert evaluate_condition('$EMPTY == ""', ENV)
    assert not evaluate_condition("$NOT_SET_ANYWHERE == x", {})
    assert evaluate_condition("$NOT_SET_ANYWHERE < a", {})


def test_the_same_condition_follows_each_environment() -> None:
    # Parsed conditions are cached; the environment must not be.
    expr = "$ROS_DISTRO == humble"
    assert evaluate_condition(expr, {"ROS_DISTRO": "humble"})
    assert not evaluate_condition(expr, {"ROS_DISTRO": "jazzy"})
    assert evaluate_condition(expr, {"ROS_DISTRO": "humble"})


def test_and_or_are_accepted_as_operands_like_catkin_pkg() -> None:
    assert evaluate_condition("$X == and", {"X": "and"})
    assert evaluate_condition("$X == or and $Y == and", {"X": "or", "Y": "and"})


@pytest.mark.parametrize(
    ("expr", "fragment"),
    [
        ("", "condition is empty"),
        ("   ", "condition is empty"),
        ("$ROS_VERSION", "expected a comparison operator"),
        ("$ROS_VERSION = 2", "single '=' at column 14"),
        ("$ROS_VERSION === 2", "single '=' at column 16"),
        ("$ROS_VERSION == 2 and", "found the end of the condition"),
        ("or $A == 1", "expected a comparison operator"),
        ("($ROS_VERSION == 2", "the '(' at column 1 is not closed"),
        ("$ROS_VERSION == 2)", "unexpected ')' at column 18"),
        ("()", "expected a $VARIABLE or a literal but found ')'"),
        ("$A == 1 == 2", "unexpected '==' at column 9"),
        ("$A == 3.12", "unexpected character '.' at column 8"),
        ("$A == 'x", "unterminated quoted literal starting at column 7"),
        ('$A == "x', "unterminated quoted literal"),
        ("$ == 1", "'$' at column 1 is not followed by a variable name"),
        ("$A == 1 && $B == 2", "unexpected character '&'"),
        ("not $A == 1", "expected a comparison operator"),
        ("$A == 1 AND $B == 2", "unexpected 'AND'"),
        ("$A == $(touch x)", "'$' at column 7"),
    ],
)
def test_malformed_conditions_raise(expr: str, fragment: str) -> None:
    with pytest.raises(ConditionError) as info:
        evaluate_condition(expr, ENV)
    error = info.value
    assert isinstance(error, ManifestError)
    text = str(error)
    assert fragment in text
    assert "\n" not in text
    assert error.hint  # every message says how to fix it


def test_newlines_and_tabs_are_whitespace() -> None:
    assert evaluate_condition("$A == 1\n\tor $B == 2", {"A": "1"})


def test_hints_point_at_the_fix() -> None:
    with pytest.raises(ConditionError) as info:
        evaluate_condition("$ROS_PYTHON_VERSION == 3.12", {})
    assert info.value.hint is not None and "quote" in info.value.hint
    with pytest.raises(ConditionError) as info:
        evaluate_condition("$ROS_VERSION = 2", {})
    assert info.value.hint == "use '==' to compare"


def test_check_condition_validates_without_an_environment() -> None:
    check_condition("$ROS_VERSION == 2 or ($ROS_DISTRO < 'k' and $X != \"\")")
    with pytest.raises(ConditionError):
        check_condition("$ROS_VERSION ==")

"""The mode state machine behind mode_server."""

from demo_nodes_py.modes import change_mode


def test_a_known_mode_is_switched_to_and_the_previous_one_reported():
    mode, change = change_mode('idle', 'position')
    assert mode == 'position'
    assert change.success and change.previous_mode == 'idle'
    assert change.message == 'switched from idle to position'


def test_an_unknown_mode_is_refused_and_the_mode_kept():
    mode, change = change_mode('velocity', 'warp')
    assert mode == 'velocity'
    assert not change.success
    assert "unknown mode 'warp'" in change.message


def test_requesting_the_current_mode_succeeds_without_change():
    mode, change = change_mode('idle', 'idle')
    assert (mode, change.success) == ('idle', True)

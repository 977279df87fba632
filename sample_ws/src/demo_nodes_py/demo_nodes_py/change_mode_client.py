"""Call `change_mode` once and print the answer: `change_mode_client MODE [--ros-args ...]`."""

from __future__ import annotations

import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from demo_interfaces.srv import ChangeMode
from demo_nodes_py.shutdown import interrupt_once

USAGE = 'usage: change_mode_client MODE [--timeout SECONDS] [--ros-args ...]'


def parse_arguments(argv: list[str]) -> tuple[str, float]:
    """MODE and the timeout from the non-ROS arguments (rclpy strips the --ros-args part)."""
    mode, timeout, rest = None, 10.0, list(argv)
    while rest:
        arg = rest.pop(0)
        if arg == '--timeout' and rest:
            timeout = float(rest.pop(0))
        elif arg.startswith('-') or mode is not None:
            raise ValueError(f'unexpected argument {arg!r}')
        else:
            mode = arg
    if mode is None:
        raise ValueError('MODE is missing')
    return mode, timeout


def main(args: list[str] | None = None) -> int:
    argv = sys.argv if args is None else args
    try:
        mode, timeout = parse_arguments(rclpy.utilities.remove_ros_args(argv)[1:])
    except ValueError as exc:
        print(f'change_mode_client: error: {exc}\n{USAGE}', file=sys.stderr)
        return 2
    interrupt_once()
    try:
        rclpy.init(args=argv)
        node = Node('change_mode_client')
        client = node.create_client(ChangeMode, 'change_mode')
        if not client.wait_for_service(timeout_sec=timeout):
            print(f'change_mode_client: error: no {client.srv_name} service after {timeout} s '
                  '(is mode_server running, with the same ROS_DOMAIN_ID?)', file=sys.stderr)
            return 1
        future = client.call_async(ChangeMode.Request(mode=mode))
        rclpy.spin_until_future_complete(node, future, timeout_sec=timeout)
        response = future.result()
        if response is None:
            print(f'change_mode_client: error: no answer within {timeout} s', file=sys.stderr)
            return 1
        print(f'success={response.success} previous_mode={response.previous_mode} '
              f'message={response.message}')
        return 0 if response.success else 3
    except (KeyboardInterrupt, ExternalShutdownException):
        return 0  # Ctrl-C: stop quietly, like the other nodes
    finally:
        rclpy.try_shutdown()


if __name__ == '__main__':
    sys.exit(main())

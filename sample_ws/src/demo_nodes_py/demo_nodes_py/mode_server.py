"""Serve `change_mode` (demo_interfaces/srv/ChangeMode): switch among idle, position, velocity."""

from __future__ import annotations

import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from demo_interfaces.srv import ChangeMode
from demo_nodes_py.modes import change_mode
from demo_nodes_py.shutdown import interrupt_once


class ModeServer(Node):

    def __init__(self) -> None:
        super().__init__('mode_server')
        self.mode = self.declare_parameter('initial_mode', 'idle').value
        self.service = self.create_service(ChangeMode, 'change_mode', self.on_request)
        self.get_logger().info(f'serving {self.service.srv_name} in {self.mode} mode')

    def on_request(self, request: ChangeMode.Request,
                   response: ChangeMode.Response) -> ChangeMode.Response:
        self.mode, change = change_mode(self.mode, request.mode)
        response.success = change.success
        response.previous_mode = change.previous_mode
        response.message = change.message
        self.get_logger().info(f"request '{request.mode}': {change.message}")
        return response


def main(args: list[str] | None = None) -> int:
    interrupt_once()
    try:
        rclpy.init(args=args)
        rclpy.spin(ModeServer())
    except (KeyboardInterrupt, ExternalShutdownException):
        pass  # Ctrl-C, or `ros2 launch` stopping the node: a normal end
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())

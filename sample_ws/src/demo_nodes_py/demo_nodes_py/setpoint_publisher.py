"""Publish a sine wave of joint setpoints on `setpoint` (std_msgs/Float64)."""

from __future__ import annotations

import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from std_msgs.msg import Float64

from demo_nodes_py.setpoints import sine_setpoint
from demo_nodes_py.shutdown import interrupt_once


class SetpointPublisher(Node):

    def __init__(self) -> None:
        super().__init__('setpoint_publisher')
        self.amplitude = self.declare_parameter('amplitude', 1.0).value
        self.period = self.declare_parameter('period', 4.0).value
        rate = self.declare_parameter('rate', 10.0).value
        self.publisher = self.create_publisher(Float64, 'setpoint', 10)
        self.start = self.get_clock().now()
        self.timer = self.create_timer(1.0 / rate, self.publish)
        self.get_logger().info(
            f'publishing on {self.publisher.topic_name}: amplitude {self.amplitude}, '
            f'period {self.period} s, {rate} Hz')

    def publish(self) -> None:
        t = (self.get_clock().now() - self.start).nanoseconds / 1e9
        self.publisher.publish(Float64(data=sine_setpoint(t, self.amplitude, self.period)))


def main(args: list[str] | None = None) -> int:
    interrupt_once()
    try:
        rclpy.init(args=args)
        rclpy.spin(SetpointPublisher())
    except (KeyboardInterrupt, ExternalShutdownException):
        pass  # Ctrl-C, or `ros2 launch` stopping the node: a normal end
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())

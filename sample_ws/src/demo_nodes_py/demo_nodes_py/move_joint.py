"""Move the joint named by parameter `joint_name` to the setpoints heard on `joint_setpoint`."""

from __future__ import annotations

import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import Float64

from demo_interfaces.msg import Setpoint
from demo_nodes_py.setpoints import clamp, describe_setpoint
from demo_nodes_py.shutdown import interrupt_once


class MissingParameter(Exception):
    """A parameter the node cannot work without was not given."""


class MoveJoint(Node):

    def __init__(self) -> None:
        super().__init__('move_joint')
        # No default: which joint to move is the one thing the node cannot guess.
        self.joint_name = self.declare_parameter('joint_name', Parameter.Type.STRING).value
        if not self.joint_name:
            raise MissingParameter(
                "parameter 'joint_name' is required: run with --ros-args -p joint_name:=<joint> "
                'or --params-file <share/demo_nodes_py>/config/params.yaml')
        self.max_velocity = self.declare_parameter('max_velocity', 1.0).value
        self.limit = self.declare_parameter('limit', 3.14).value
        self.max_messages = self.declare_parameter('max_messages', 0).value
        self.received = 0
        self.done = False
        self.applied = self.create_publisher(Setpoint, 'applied_setpoint', 10)
        self.subscription = self.create_subscription(
            Float64, 'joint_setpoint', self.on_setpoint, 10)
        self.get_logger().info(
            f'move_joint ready: joint {self.joint_name}, max_velocity {self.max_velocity}, '
            f'listening on {self.subscription.topic_name}')

    def on_setpoint(self, msg: Float64) -> None:
        position = clamp(msg.data, self.limit)
        self.get_logger().info(describe_setpoint(self.joint_name, position))
        out = Setpoint(joint_name=self.joint_name, position=position)
        out.header.stamp = self.get_clock().now().to_msg()
        self.applied.publish(out)
        self.received += 1
        if self.max_messages and self.received >= self.max_messages:
            self.get_logger().info(f'received {self.received} setpoints, done')
            self.done = True


def main(args: list[str] | None = None) -> int:
    interrupt_once()
    try:
        rclpy.init(args=args)
        node = MoveJoint()
        while rclpy.ok() and not node.done:
            rclpy.spin_once(node)
    except MissingParameter as exc:
        print(f'move_joint: error: {exc}', file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass  # Ctrl-C, or `ros2 launch` stopping the node: a normal end
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())

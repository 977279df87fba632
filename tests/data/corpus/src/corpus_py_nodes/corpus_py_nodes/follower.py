# Copyright 2024 wsbuild developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.


"""The route follower: publishes each point of the routes it receives."""

from corpus_base_msgs.msg import StampedPoint
from corpus_interfaces.msg import Route
import rclpy
from rclpy.node import Node


class Follower(Node):

    def __init__(self):
        super().__init__('route_follower')
        self.publisher = self.create_publisher(StampedPoint, 'current_point', 10)
        self.create_subscription(Route, 'route', self.on_route, 10)

    def on_route(self, route):
        for point in route.points:
            message = StampedPoint(point=point)
            message.header.stamp = self.get_clock().now().to_msg()
            message.header.frame_id = route.name
            self.publisher.publish(message)


def main(args=None):
    rclpy.init(args=args)
    node = Follower()
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()

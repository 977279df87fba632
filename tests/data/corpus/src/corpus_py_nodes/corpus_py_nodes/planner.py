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


"""The route planner: a PlanRoute service, or one plan printed with --plan X0 Y0 X1 Y1."""

import sys

from corpus_base_msgs.msg import Point2D
from corpus_interfaces.msg import Route
from corpus_interfaces.srv import PlanRoute
import rclpy
from rclpy.node import Node

from .geometry import length
from .geometry import straight_route


def plan(start, goal, steps=4):
    """Return a PlanRoute response for a straight route from `start` to `goal`."""
    response = PlanRoute.Response()
    response.route = Route(name='straight', points=straight_route(start, goal, steps))
    response.success = True
    return response


class Planner(Node):

    def __init__(self):
        super().__init__('route_planner')
        self.declare_parameter('steps', 4)
        self.create_service(PlanRoute, 'plan_route', self.on_request)

    def on_request(self, request, response):
        steps = self.get_parameter('steps').value
        planned = plan(request.start, request.goal, steps)
        response.success, response.route = planned.success, planned.route
        self.get_logger().info(f'planned {len(response.route.points)} points')
        return response


def main(args=None):
    argv = sys.argv[1:] if args is None else args
    if argv[:1] == ['--plan']:
        x0, y0, x1, y1 = (float(value) for value in argv[1:5])
        route = plan(Point2D(x=x0, y=y0), Point2D(x=x1, y=y1)).route
        print(f'{route.name}: {len(route.points)} points, length {length(route.points):.3f}')
        return 0
    rclpy.init(args=args)
    node = Planner()
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())

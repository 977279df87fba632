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

from corpus_base_msgs.msg import Point2D
from corpus_py_nodes.geometry import length
from corpus_py_nodes.planner import plan


def test_straight_route_has_steps_plus_one_points():
    response = plan(Point2D(x=0.0, y=0.0), Point2D(x=3.0, y=4.0), steps=5)
    assert response.success
    assert len(response.route.points) == 6
    assert length(response.route.points) == 5.0

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


"""Route geometry on plain numbers and corpus_base_msgs points."""

from corpus_base_msgs.msg import Point2D
import numpy


def straight_route(start, goal, steps):
    """Return `steps` + 1 points on the segment from `start` to `goal`, both included."""
    xs = numpy.linspace(start.x, goal.x, steps + 1)
    ys = numpy.linspace(start.y, goal.y, steps + 1)
    return [Point2D(x=float(x), y=float(y)) for x, y in zip(xs, ys)]


def length(points):
    """Return the length of the polyline through `points`."""
    coords = numpy.array([[p.x, p.y] for p in points], dtype=float)
    if len(coords) < 2:
        return 0.0
    return float(numpy.sum(numpy.linalg.norm(numpy.diff(coords, axis=0), axis=1)))

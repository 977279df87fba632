// Copyright 2024 wsbuild developers
//
// Licensed under the Apache License, Version 2.0 (the "License");
// you may not use this file except in compliance with the License.
// You may obtain a copy of the License at
//
//     http://www.apache.org/licenses/LICENSE-2.0
//
// Unless required by applicable law or agreed to in writing, software
// distributed under the License is distributed on an "AS IS" BASIS,
// WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
// See the License for the specific language governing permissions and
// limitations under the License.

#include <cstdlib>
#include <iostream>
#include <vector>

#include "corpus_base_msgs/msg/point2_d.hpp"
#include "corpus_core_lib/geometry.hpp"
#include "corpus_header_lib/clamp.hpp"

int main(int argc, char ** argv)
{
  // route_length X0 Y0 X1 Y1 ...: the length of the polyline, clamped to [0, 1000]
  std::vector<corpus_base_msgs::msg::Point2D> points;
  for (int i = 1; i + 1 < argc; i += 2) {
    corpus_base_msgs::msg::Point2D point;
    point.x = std::atof(argv[i]);
    point.y = std::atof(argv[i + 1]);
    points.push_back(point);
  }
  double length = 0.0;
  for (size_t i = 1; i < points.size(); ++i) {
    length += corpus_core_lib::distance(points[i - 1], points[i]);
  }
  std::cout << corpus_header_lib::clamp(length, 0.0, 1000.0) << std::endl;
  return 0;
}

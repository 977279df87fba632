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

#include "corpus_core_lib/geometry.hpp"

#include <cmath>

#include "corpus_header_lib/clamp.hpp"

namespace corpus_core_lib
{

double distance(const corpus_base_msgs::msg::Point2D & a, const corpus_base_msgs::msg::Point2D & b)
{
  return std::hypot(b.x - a.x, b.y - a.y);
}

corpus_base_msgs::msg::Point2D interpolate(
  const corpus_base_msgs::msg::Point2D & a, const corpus_base_msgs::msg::Point2D & b,
  double fraction)
{
  const double t = corpus_header_lib::clamp(fraction, 0.0, 1.0);
  corpus_base_msgs::msg::Point2D result;
  result.x = a.x + t * (b.x - a.x);
  result.y = a.y + t * (b.y - a.y);
  return result;
}

}  // namespace corpus_core_lib

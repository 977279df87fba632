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

#ifndef CORPUS_CORE_LIB__GEOMETRY_HPP_
#define CORPUS_CORE_LIB__GEOMETRY_HPP_

#include "corpus_base_msgs/msg/point2_d.hpp"

namespace corpus_core_lib
{

/// Euclidean distance between two points.
double distance(const corpus_base_msgs::msg::Point2D & a, const corpus_base_msgs::msg::Point2D & b);

/// The point `fraction` of the way from `a` to `b`; `fraction` is clamped to [0, 1].
corpus_base_msgs::msg::Point2D interpolate(
  const corpus_base_msgs::msg::Point2D & a, const corpus_base_msgs::msg::Point2D & b,
  double fraction);

}  // namespace corpus_core_lib

#endif  // CORPUS_CORE_LIB__GEOMETRY_HPP_

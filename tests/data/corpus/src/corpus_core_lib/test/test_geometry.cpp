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

#include <gtest/gtest.h>

#include "corpus_core_lib/geometry.hpp"

TEST(geometry, distance)
{
  corpus_base_msgs::msg::Point2D a;
  corpus_base_msgs::msg::Point2D b;
  b.x = 3.0;
  b.y = 4.0;
  EXPECT_DOUBLE_EQ(corpus_core_lib::distance(a, b), 5.0);
}

TEST(geometry, interpolate_clamps)
{
  corpus_base_msgs::msg::Point2D a;
  corpus_base_msgs::msg::Point2D b;
  b.x = 2.0;
  EXPECT_DOUBLE_EQ(corpus_core_lib::interpolate(a, b, 0.5).x, 1.0);
  EXPECT_DOUBLE_EQ(corpus_core_lib::interpolate(a, b, 7.0).x, 2.0);
}

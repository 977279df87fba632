#include <gtest/gtest.h>

#include "demo_cpp_lib/joint_limits.hpp"

TEST(JointLimits, PositionsInsideTheLimitsAreKept)
{
  EXPECT_DOUBLE_EQ(demo_cpp_lib::clamp_position(1.0, {-2.0, 2.0}), 1.0);
}

TEST(JointLimits, PositionsOutsideTheLimitsAreClamped)
{
  EXPECT_DOUBLE_EQ(demo_cpp_lib::clamp_position(5.0, {-2.0, 2.0}), 2.0);
  EXPECT_DOUBLE_EQ(demo_cpp_lib::clamp_position(-5.0, {-2.0, 2.0}), -2.0);
}

TEST(JointLimits, TheDescriptionConvertsDegreesAndNamesTheJoint)
{
  EXPECT_EQ(
    demo_cpp_lib::describe_command("right_e0", 90.0, demo_cpp_lib::elbow_limits()),
    "right_e0: 90.0 deg -> 1.571 rad (limits [-3.05, 3.05])");
}

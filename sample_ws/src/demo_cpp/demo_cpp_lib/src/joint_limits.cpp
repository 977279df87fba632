#include "demo_cpp_lib/joint_limits.hpp"

#include <algorithm>
#include <cstdio>

namespace demo_cpp_lib
{

JointLimits elbow_limits()
{
  return JointLimits{-3.05, 3.05};
}

double clamp_position(double position, const JointLimits & limits)
{
  return std::clamp(position, limits.lower, limits.upper);
}

std::string describe_command(const std::string & joint, double degrees, const JointLimits & limits)
{
  const double clamped = clamp_position(demo_tools::degrees_to_radians(degrees), limits);
  char buffer[160];
  std::snprintf(
    buffer, sizeof(buffer), "%s: %.1f deg -> %.3f rad (limits [%.2f, %.2f])",
    joint.c_str(), degrees, clamped, limits.lower, limits.upper);
  return buffer;
}

}  // namespace demo_cpp_lib

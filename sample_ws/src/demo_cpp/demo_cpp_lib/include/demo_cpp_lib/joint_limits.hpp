// Joint limits of the sample robot's arm: clamping and describing a commanded position.
#pragma once

#include <string>

#include "demo_tools/units.hpp"

namespace demo_cpp_lib
{

struct JointLimits
{
  double lower;  // radians
  double upper;  // radians
};

// The limits of the elbow joint "e0" in demo_parts/urdf/arm.xacro.
JointLimits elbow_limits();

// `position` (radians) clamped into `limits`.
double clamp_position(double position, const JointLimits & limits);

// A one-line summary: "<joint>: <deg> deg -> <clamped> rad (limits [<lower>, <upper>])".
std::string describe_command(const std::string & joint, double degrees, const JointLimits & limits);

}  // namespace demo_cpp_lib

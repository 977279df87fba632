// joint_command JOINT DEGREES: print the position demo_cpp_lib would command.
#include <cstdlib>
#include <iostream>
#include <string>

#include "demo_cpp_lib/joint_limits.hpp"

int main(int argc, char ** argv)
{
  if (argc != 3) {
    std::cerr << "usage: joint_command JOINT DEGREES   (e.g. joint_command right_e0 90)\n";
    return 2;
  }
  char * end = nullptr;
  const double degrees = std::strtod(argv[2], &end);
  if (end == argv[2] || *end != '\0') {
    std::cerr << "joint_command: error: DEGREES must be a number, got '" << argv[2] << "'\n";
    return 2;
  }
  std::cout << demo_cpp_lib::describe_command(argv[1], degrees, demo_cpp_lib::elbow_limits())
            << std::endl;
  return 0;
}

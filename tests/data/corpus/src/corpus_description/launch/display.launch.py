"""Publish the robot description of corpus_bot."""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import Command, LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue


def generate_launch_description():
    share = get_package_share_directory('corpus_description')
    description = Command([
        'xacro ', os.path.join(share, 'urdf', 'robot.urdf.xacro'),
        ' wheel_radius:=', LaunchConfiguration('wheel_radius'),
    ])
    return LaunchDescription([
        DeclareLaunchArgument('wheel_radius', default_value='0.1'),
        Node(
            package='robot_state_publisher',
            executable='robot_state_publisher',
            parameters=[
                os.path.join(share, 'config', 'display.yaml'),
                {'robot_description': ParameterValue(description, value_type=str)},
            ],
        ),
    ])

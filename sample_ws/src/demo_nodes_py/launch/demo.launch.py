"""Bring up the demo under /arm: publisher, move_joint remapped onto it, and the mode server."""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    params = os.path.join(get_package_share_directory('demo_nodes_py'), 'config', 'params.yaml')
    namespace = LaunchConfiguration('namespace')
    return LaunchDescription([
        DeclareLaunchArgument('namespace', default_value='arm',
                              description='namespace of every node'),
        DeclareLaunchArgument('with_mode_server', default_value='true',
                              description='also start the ChangeMode server'),
        Node(package='demo_nodes_py', executable='setpoint_publisher', namespace=namespace,
             parameters=[params], output='screen'),
        Node(package='demo_nodes_py', executable='move_joint', namespace=namespace,
             remappings=[('joint_setpoint', 'setpoint')],
             parameters=[params, {'max_velocity': 0.5}], output='screen'),
        Node(package='demo_nodes_py', executable='mode_server', namespace=namespace,
             parameters=[params], output='screen',
             condition=IfCondition(LaunchConfiguration('with_mode_server'))),
    ])

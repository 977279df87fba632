from launch import LaunchDescription
from launch_ros.actions import Node


def generate_launch_description():
    return LaunchDescription([
        Node(package='corpus_py_nodes', executable='route_planner',
             parameters=[{'steps': 8}]),
        Node(package='corpus_py_nodes', executable='route_follower'),
    ])

from glob import glob

from setuptools import find_packages, setup

package_name = 'demo_nodes_py'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
        ('share/' + package_name + '/launch', glob('launch/*.launch.*')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='wsbuild developers',
    maintainer_email='dev@example.com',
    description='Python nodes of the sample workspace',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'setpoint_publisher = demo_nodes_py.setpoint_publisher:main',
            'move_joint = demo_nodes_py.move_joint:main',
            'mode_server = demo_nodes_py.mode_server:main',
            'change_mode_client = demo_nodes_py.change_mode_client:main',
        ],
    },
)

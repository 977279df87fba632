from glob import glob
import os

from setuptools import find_packages
from setuptools import setup

package_name = 'corpus_py_nodes'

setup(
    name=package_name,
    version='0.9.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        (os.path.join('share', package_name, 'launch'), glob('launch/*.launch.*')),
        (os.path.join('share', package_name, 'config'), glob(os.path.join('config', '*.yaml'))),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    author='wsbuild developers',
    author_email='dev@example.com',
    maintainer='wsbuild developers',
    maintainer_email='dev@example.com',
    keywords=['ROS'],
    classifiers=[
        'Intended Audience :: Developers',
        'License :: OSI Approved :: Apache Software License',
        'Programming Language :: Python',
        'Topic :: Software Development',
    ],
    description='Route planner and follower nodes.',
    license='Apache License, Version 2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'route_planner = corpus_py_nodes.planner:main',
            'route_follower = corpus_py_nodes.follower:main',
        ],
    },
)

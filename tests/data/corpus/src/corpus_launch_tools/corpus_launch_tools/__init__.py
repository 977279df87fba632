# Copyright 2024 wsbuild developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.


"""Helpers for launch files: find files in installed packages."""

import os

from ament_index_python.packages import get_package_share_directory

__all__ = ['share_file']


def share_file(package, *parts):
    """Return the path of a file in an installed package's share directory."""
    path = os.path.join(get_package_share_directory(package), *parts)
    if not os.path.exists(path):
        raise FileNotFoundError(path)
    return path

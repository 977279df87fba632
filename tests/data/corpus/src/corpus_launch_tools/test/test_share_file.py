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

import os

from corpus_launch_tools import share_file
import pytest


def test_finds_its_own_manifest():
    path = share_file('corpus_launch_tools', 'package.xml')
    assert os.path.basename(path) == 'package.xml'


def test_missing_file_is_an_error():
    with pytest.raises(FileNotFoundError):
        share_file('corpus_launch_tools', 'no_such_file')

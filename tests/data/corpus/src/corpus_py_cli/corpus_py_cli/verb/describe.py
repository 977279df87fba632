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


from importlib.resources import files

from ament_index_python.packages import get_package_prefix


class DescribeVerb:
    """Describe an installed package with the template shipped as package data."""

    def add_arguments(self, parser, cli_name):
        parser.add_argument('package')

    def main(self, *, args):
        template = files('corpus_py_cli').joinpath('templates', 'describe.txt').read_text()
        print(template.format(name=args.package, prefix=get_package_prefix(args.package)))
        return 0

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


import argparse
import sys

from corpus_py_cli.command import load_verbs


class CorpusCommand:
    """Various corpus related sub-commands."""

    def add_arguments(self, parser, cli_name):
        self._verbs = load_verbs()
        subparsers = parser.add_subparsers(dest='verb', required=True)
        for name, verb in self._verbs.items():
            verb.add_arguments(subparsers.add_parser(name, help=verb.__doc__), cli_name)

    def main(self, *, parser, args):
        return self._verbs[args.verb].main(args=args)


def main(argv=None):
    parser = argparse.ArgumentParser(prog='corpus_cli')
    command = CorpusCommand()
    command.add_arguments(parser, 'corpus_cli')
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    return command.main(parser=parser, args=args)

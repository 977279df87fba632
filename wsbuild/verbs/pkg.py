"""`wsbuild pkg create`: arguments, defaults from the environment, and what the user is told."""

from __future__ import annotations

import argparse
import os
import re
import sys
from pathlib import Path

from wsbuild.errors import WsbuildError

CREATE_DOC = """Create a new package from templates (`ros2 pkg create`'s options, plus --launch).

The package goes into the workspace's src/ (or the current directory when that is inside
src/ or no workspace is found), unless --destination-directory says otherwise. Nothing is
written when an option is invalid or the directory exists.

--node-name makes a plain program; with rclpy (ament_python) or rclcpp (ament_cmake) among
--dependencies it is a ROS node declaring the parameter `greeting`. --launch adds
launch/<node>.launch.py and .launch.xml and config/params.yaml, installed to
share/<package>/. The maintainer defaults to `git config user.name/user.email`.

examples:
  wsbuild pkg create my_py_pkg --build-type ament_python --dependencies rclpy \\
      --node-name talker --launch
  wsbuild pkg create my_cpp_pkg --dependencies std_msgs --library-name my_lib --node-name my_node
  wsbuild pkg create my_pkg --license '?'
"""


def add_pkg_create_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments of `pkg create` (those of `ros2 pkg create`, plus --launch)."""
    from wsbuild.create.licenses import NO_LICENSE  # lazy: off Tab completion and `--help`
    from wsbuild.create.templates import available_build_types  # lazy: off Tab completion
    from wsbuild.create.validation import (
        DEFAULT_BUILD_TYPE, DEFAULT_DESCRIPTION, PACKAGE_FORMATS)  # lazy: off Tab completion

    try:
        build_types = ", ".join(available_build_types())
    except (WsbuildError, OSError):  # a broken install must not break --help; create reports it
        build_types = "see the templates"
    parser.add_argument("package_name", nargs="?", metavar="NAME",
                        help="the package name (REP 144: lowercase letters, digits, underscores)")
    parser.add_argument("--build-type", default=DEFAULT_BUILD_TYPE, metavar="TYPE",
                        help=f"{build_types} (default: {DEFAULT_BUILD_TYPE})")
    parser.add_argument("--dependencies", nargs="+", default=[], metavar="DEP",
                        help="packages this one depends on (<depend> in package.xml)")
    parser.add_argument("--node-name", metavar="NAME", help="create an executable of this name")
    parser.add_argument("--library-name", metavar="NAME", help="create a library of this name")
    parser.add_argument("--launch", action="store_true",
                        help="add a launch file and config/params.yaml for the node "
                             "(needs --node-name)")
    parser.add_argument("--description", default=DEFAULT_DESCRIPTION,
                        help="the package.xml description")
    parser.add_argument("--license", default=NO_LICENSE, metavar="SPDX",
                        help="an SPDX license id, e.g. Apache-2.0; '?' lists those that get a "
                             "LICENSE file")
    parser.add_argument("--maintainer-name", metavar="NAME",
                        help="default: git config user.name, else the login name")
    parser.add_argument("--maintainer-email", metavar="EMAIL",
                        help="default: git config user.email")
    parser.add_argument("--package-format", type=int, default=3, choices=PACKAGE_FORMATS,
                        help="package.xml format (default: 3)")
    parser.add_argument("--destination-directory", metavar="DIR",
                        help="where to create the package directory (default: the workspace's "
                             "src/)")


def run_pkg_create(args: argparse.Namespace) -> int:
    """Create a new package."""
    from wsbuild.create.licenses import LICENSES  # lazy: off Tab completion and `--help`
    from wsbuild.create.defaults import (
        default_destination, default_maintainer)  # lazy: off Tab completion
    from wsbuild.create.validation import PackageRequest  # lazy: off Tab completion and `--help`
    from wsbuild.create.writing import create_package  # lazy: off Tab completion and `--help`

    if args.license == "?":
        width = max(len(entry.spdx) for entry in LICENSES)
        for entry in LICENSES:
            print(f"{entry.spdx:<{width}}  {entry.title}")
        return 0
    if not args.package_name:
        hint = "wsbuild pkg create NAME [options]"
        if args.dependencies:
            hint += "; NAME goes before --dependencies, which takes every word after it"
        raise WsbuildError("missing the package name", hint=hint)
    cwd = Path.cwd()
    if args.destination_directory:
        destination = Path(os.path.abspath(args.destination_directory))
    else:
        destination = default_destination(cwd)
    notes: list[str] = []
    name, email = args.maintainer_name, args.maintainer_email
    if name is None or email is None:
        found = default_maintainer(destination if destination.is_dir() else cwd)
        name = found.name if name is None else name
        if email is None:
            email = found.email
            if found.note:
                notes.append(found.note)
    request = PackageRequest(
        name=args.package_name,
        destination=destination,
        maintainer_name=name,
        maintainer_email=email,
        build_type=args.build_type,
        dependencies=tuple(args.dependencies),
        node_name=args.node_name,
        library_name=args.library_name,
        launch=args.launch,
        description=args.description,
        license=args.license,
        package_format=args.package_format,
    )
    created = create_package(request)
    shown = _relative(created.path, cwd)
    print(f"created {created.build_type} package '{created.name}' in {shown} "
          f"(templates: {', '.join(created.variants)})")
    for path in created.files:
        print(f"  {path}")
    notes += _without_wheel(created.path, destination)
    for note in (*notes, *created.notes):
        print(f"note: {note}", file=sys.stderr)
    print("next:")
    print(f"  wsbuild build --packages-select {created.name}")
    print("  source install/setup.bash")
    if args.node_name:
        print(f"  wsbuild run {created.name} {args.node_name}")
    return 0


def _without_wheel(package: Path, src: Path) -> list[str]:
    """A note for each dependency of the new package that has no wheel and that neither the
    underlays' ament index nor the workspace's sources hold (rclcpp on a pip-only machine):
    what building it then takes."""
    from wsbuild.underlay.detect import find_venv_underlay  # lazy: off Tab completion and `--help`
    from wsbuild.underlay.wheels import NO_WHEEL, no_wheel_advice  # lazy: off Tab completion
    from wsbuild.workspace.resolve import ament_index  # lazy: off Tab completion and `--help`

    text = (package / "package.xml").read_text()
    declared = re.findall(r"<(?:\w+_)?depend(?: [^>]*)?>\s*([\w-]+)\s*</", text)
    wanted = [dep for dep in dict.fromkeys(declared) if dep in NO_WHEEL]
    if not wanted:
        return []
    prefixes = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    venv = find_venv_underlay(os.environ, sys.executable)
    installed = ament_index([*prefixes, *([venv] if venv else [])])
    sources = {match for manifest in src.glob("**/package.xml") if manifest.parent != package
               for match in re.findall(r"<name>\s*([\w-]+)\s*</name>", manifest.read_text())}
    return [f"{no_wheel_advice(dep)}; until then `wsbuild build` of {package.name} fails on it"
            for dep in wanted if dep not in installed and dep not in sources]


def _relative(path: Path, cwd: Path) -> str:
    try:
        return str(path.relative_to(cwd))
    except ValueError:
        return str(path)

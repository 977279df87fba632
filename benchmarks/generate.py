"""Synthetic ROS 2 workspaces for the benchmarks: seeded, nested, real ament_python/ament_cmake packages."""

from __future__ import annotations

import random
from dataclasses import dataclass
from pathlib import Path

#: like `ros2 pkg create --build-type ament_python --node-name node`: real package.xml (format 3)
PACKAGE_XML = """<?xml version="1.0"?>
<?xml-model href="http://download.ros.org/schema/package_format3.xsd" schematypens="http://www.w3.org/2001/XMLSchema"?>
<package format="3">
  <name>{name}</name>
  <version>0.0.0</version>
  <description>Synthetic benchmark package {name}</description>
  <maintainer email="bench@example.com">bench</maintainer>
  <license>Apache-2.0</license>
{buildtool}{depends}
  <export>
    <build_type>{build_type}</build_type>
  </export>
</package>
"""

SETUP_PY = """from setuptools import find_packages, setup

package_name = '{name}'

setup(
    name=package_name,
    version='0.0.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages',
            ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='bench',
    maintainer_email='bench@example.com',
    description='Synthetic benchmark package {name}',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={{
        'console_scripts': [
            'node = {name}.node:main'
        ],
    }},
)
"""

SETUP_CFG = """[develop]
script_dir=$base/lib/{name}
[install]
install_scripts=$base/lib/{name}
"""

NODE_PY = """\"\"\"Node of {name}.\"\"\"


def main():
    print('Hi from {name}.')


if __name__ == '__main__':
    main()
"""

CMAKELISTS = """cmake_minimum_required(VERSION 3.8)
project({name} NONE)

find_package(ament_cmake REQUIRED)

install(FILES config/params.yaml DESTINATION share/${{PROJECT_NAME}}/config)

ament_package()
"""

PARAMS_YAML = """{name}:
  ros__parameters:
    rate: 10
"""


@dataclass(frozen=True, slots=True)
class WorkspaceSpec:
    """What to generate: package counts, the seed of the dependency DAG and its density."""

    python_packages: int
    cmake_packages: int = 0
    seed: int = 1
    #: each package depends on 0..max_deps packages generated before it
    max_deps: int = 3
    #: packages per innermost folder (src/<group>/<subgroup>/<pkg>)
    folder_size: int = 8

    @property
    def total(self) -> int:
        return self.python_packages + self.cmake_packages


@dataclass(frozen=True, slots=True)
class GeneratedPackage:
    name: str
    build_type: str
    #: relative to the workspace root
    path: Path
    #: workspace packages this one depends on (sorted)
    depends: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class GeneratedWorkspace:
    root: Path
    packages: tuple[GeneratedPackage, ...]

    def by_name(self, name: str) -> GeneratedPackage:
        return next(p for p in self.packages if p.name == name)

    def edges(self) -> set[tuple[str, str]]:
        """(dependent, dependency) pairs."""
        return {(p.name, d) for p in self.packages for d in p.depends}

    def leaves(self) -> list[str]:
        """ament_python packages nothing depends on (sorted)."""
        used = {d for p in self.packages for d in p.depends}
        return sorted(p.name for p in self.packages
                      if p.name not in used and p.build_type == "ament_python")

    def module_of(self, name: str) -> Path:
        """The node module of an ament_python package (absolute): the file the edit scenario touches."""
        package = self.by_name(name)
        return self.root / package.path / name / "node.py"


def plan_packages(spec: WorkspaceSpec) -> list[GeneratedPackage]:
    """The packages and their seeded random DAG, without touching the disk.

    ament_cmake packages come first in generation order (the libraries/interfaces at the bottom
    of a real stack); every package depends on up to `max_deps` earlier packages, so the graph is
    acyclic by construction.  Dependencies prefer recent packages, which gives the graph depth
    (a chain of dependents) rather than a flat fan-in on the first few.
    """
    rng = random.Random(spec.seed)
    kinds = ["ament_cmake"] * spec.cmake_packages + ["ament_python"] * spec.python_packages
    names: list[str] = []
    counters = {"ament_cmake": 0, "ament_python": 0}
    for kind in kinds:
        counters[kind] += 1
        short = "cmake" if kind == "ament_cmake" else "py"
        names.append(f"bench_{short}_{counters[kind]:04d}")
    planned: list[GeneratedPackage] = []
    width = max(spec.folder_size, 1)
    for index, (name, kind) in enumerate(zip(names, kinds)):
        candidates = list(range(index))
        if kind == "ament_cmake":
            candidates = [i for i in candidates if kinds[i] == "ament_cmake"]
        count = min(rng.randint(0, spec.max_deps), len(candidates))
        # triangular preference for recent packages: depth grows with the workspace
        chosen: set[int] = set()
        while len(chosen) < count:
            slot = int(len(candidates) * rng.random() ** 0.5)
            chosen.add(candidates[min(slot, len(candidates) - 1)])
        group, rest = divmod(index, width * 4)
        path = Path("src") / f"stack_{group:03d}" / f"part_{rest // width}" / name
        planned.append(GeneratedPackage(
            name=name, build_type=kind, path=path,
            depends=tuple(sorted(names[i] for i in chosen)),
        ))
    return planned


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.is_file() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def _write_package(root: Path, package: GeneratedPackage) -> None:
    base = root / package.path
    name = package.name
    depends = "".join(f"  <depend>{d}</depend>\n" for d in package.depends)
    if package.build_type == "ament_cmake":
        _write(base / "package.xml", PACKAGE_XML.format(
            name=name, build_type="ament_cmake", depends=depends,
            buildtool="  <buildtool_depend>ament_cmake</buildtool_depend>\n",
        ))
        _write(base / "CMakeLists.txt", CMAKELISTS.format(name=name))
        _write(base / "config" / "params.yaml", PARAMS_YAML.format(name=name))
        return
    _write(base / "package.xml", PACKAGE_XML.format(
        name=name, build_type="ament_python", depends=depends, buildtool="",
    ))
    _write(base / "setup.py", SETUP_PY.format(name=name))
    _write(base / "setup.cfg", SETUP_CFG.format(name=name))
    _write(base / "resource" / name, "")
    _write(base / name / "__init__.py", "")
    _write(base / name / "node.py", NODE_PY.format(name=name))


def generate_workspace(root: Path, spec: WorkspaceSpec) -> GeneratedWorkspace:
    """Write the workspace's `src/` under `root` (idempotent: unchanged files keep their mtime)."""
    root = root.resolve()
    planned = plan_packages(spec)
    for package in planned:
        _write_package(root, package)
    return GeneratedWorkspace(root=root, packages=tuple(planned))

"""One package build's (or test run's) observed steps: each command (and each request a warm
helper runs for an in-process step) writes what its processes read into a directory of its
own (`build/<pkg>/.wsbuild/observe/` for a build, `observe-test/` for its tests), and the
environment each step saw is kept in memory (never written) until the package's record takes
the digests of the variables read.

Where the run has no observer (no C compiler to build it), every step counts as not fully
observed, and the package is built every time (its record says why)."""

from __future__ import annotations

import shutil
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.files import private_directory
from wsbuild.observe.library import Observer
from wsbuild.observe.log import Observation, read_observation
from wsbuild.observe.step_environment import observed, unobserved

#: runs a program under the build-step oracle: (argv, step label, env) -> (argv, env)
Tracer = Callable[[Sequence[str], str, Mapping[str, str]],
                  tuple[Sequence[str], Mapping[str, str]]]
#: under the package's build directory: its build's steps, its tests'
OBSERVE_DIR = Path(".wsbuild") / "observe"
OBSERVE_TEST_DIR = Path(".wsbuild") / "observe-test"
#: what a warm helper read when it started (its directory is written once): read once
_settled: dict[tuple[str, tuple[Path, ...]], Observation] = {}


@dataclass(frozen=True, slots=True)
class StepRead:
    """What one step read, and the environment it saw (observer's additions taken out)."""

    label: str
    observation: Observation
    environ: Mapping[str, str | None]


@dataclass(slots=True)
class StepObservations:
    """The observed steps of one package build, in order."""

    root: Path
    #: the observer, or why there is none
    observer: Observer | str
    #: variables wsbuild set for this run only (its jobserver, a stage, the compiler cache's
    #: private files): never an input of the record
    run_only: set[str] = field(default_factory=set)
    steps: list[StepRead] = field(default_factory=list)
    #: directories whose reads are a tool's own state (a compiler cache's storage), and the
    #: variables a tool (by executable name) reads only to find its configuration and state
    tool_state: tuple[Path, ...] = ()
    tool_variables: Mapping[str, frozenset[str]] = field(default_factory=dict)
    #: runs a program under the suite's build-step oracle (builder/oracles/step_trace.py), or None
    tracer: Tracer | None = None
    _open: dict[str, tuple[str, Path, Mapping[str, str]]] = field(default_factory=dict)
    _count: int = 0

    def start(self) -> None:
        """A fresh directory for this build's observations (the last build's go)."""
        shutil.rmtree(self.root, ignore_errors=True)
        private_directory(self.root)

    @property
    def active(self) -> bool:
        return isinstance(self.observer, Observer)

    def begin(self, label: str, env: Mapping[str, str],
              run_only: Iterable[str] = ()) -> tuple[str, dict[str, str]]:
        """A command of step `label` starts with `env` (`run_only`: what of it wsbuild set for
        this run only): a token for `finish`, and the environment it runs with, observed
        when the run can observe."""
        self.run_only.update(run_only)
        directory = self.directory(label)
        token = str(directory)
        self._open[token] = (label, directory, dict(env))
        if not isinstance(self.observer, Observer):
            return token, dict(env)
        return token, observed(env, self.observer, directory)

    def directory(self, label: str) -> Path:
        """A new directory for the processes of step `label` to write into."""
        self._count += 1
        safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in label) or "step"
        return private_directory(self.root / f"{self._count:02d}-{safe}")

    def finish(self, token: str) -> None:
        """The command `begin` returned `token` for ended: what its processes wrote down."""
        label, directory, env = self._open.pop(token)
        self.add(label, directory, env)

    def add(self, label: str, directory: Path, env: Mapping[str, str]) -> None:
        """What the processes that wrote into `directory` read, for step `label` that ran
        with `env` (a warm helper's request: in-process steps)."""
        observer = self.observer
        if isinstance(observer, Observer):
            key = (str(directory), self.tool_state)
            observation = _settled.get(key) if not str(directory).startswith(
                str(self.root)) else None
            if observation is None:
                observation = read_observation(
                    directory, ignored=(observer.library.parent, *self.tool_state),
                    tool_variables=self.tool_variables)
                if not str(directory).startswith(str(self.root)):
                    _settled[key] = observation
            seen = {name: unobserved(name, value, observer) for name, value in env.items()}
        else:
            observation = Observation(unobserved=(f"nothing was observed: {observer}",))
            seen = dict(env)
        self.steps.append(StepRead(label, observation, seen))

    @property
    def tracing(self) -> bool:
        """Whether programs run under the build-step oracle (`trace`)."""
        return self.tracer is not None

    def trace(self, argv: Sequence[str], label: str, env: Mapping[str, str]
              ) -> tuple[Sequence[str], Mapping[str, str]] | None:
        """`argv` and `env` run under the build-step oracle as step `label`'s, when it is on
        (a warm helper so traced serves one request only); else None."""
        return self.tracer(argv, label, env) if self.tracer is not None else None

    def request_environment(self, env: Mapping[str, str], directory: Path) -> dict[str, str]:
        """`env` as the processes of a warm helper's request run with it."""
        if not isinstance(self.observer, Observer):
            return dict(env)
        return observed(env, self.observer, directory)

    def helper_environment(self, env: Mapping[str, str], directory: Path) -> dict[str, str]:
        """The environment a warm helper process starts with: observed into `directory`
        while it starts (it stops observing until a request names where to write)."""
        if not isinstance(self.observer, Observer):
            return dict(env)
        return observed(env, self.observer, directory)

"""The dependency graph among workspace packages: edges, topological order, cycles."""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterable, Mapping
from dataclasses import dataclass, field

from wsbuild.errors import CycleError
from wsbuild.workspace.model import CATEGORY_KINDS, DepCategory, DepKind, Package

ALL_CATEGORIES = (DepCategory.BUILD, DepCategory.RUN, DepCategory.TEST)


@dataclass(frozen=True, slots=True)
class Graph:
    """Direct edges between workspace packages, per dependency category."""

    packages: Mapping[str, Package]
    #: package -> category -> names of workspace packages it depends on
    edges: Mapping[str, Mapping[DepCategory, frozenset[str]]]
    #: build_closure's answers (a plan asks for each package's twice)
    _closures: dict[str, frozenset[str]] = field(default_factory=dict, compare=False,
                                                 repr=False)
    #: reverse_edges' answer, made on the first question
    _reverse: dict[str, frozenset[str]] = field(default_factory=dict, compare=False,
                                                repr=False)
    #: the whole graph's topological order, made on the first question (a build asks for it
    #: while selecting, planning, printing and finishing)
    _order: list[str] = field(default_factory=list, compare=False, repr=False)

    def direct(self, name: str, categories: Collection[DepCategory] = ALL_CATEGORIES) -> set[str]:
        per_category = self.edges[name]
        return set().union(*(per_category[c] for c in categories))

    def dependencies(self, names: Iterable[str],
                     categories: Collection[DepCategory] = ALL_CATEGORIES) -> set[str]:
        """All packages `names` depend on, recursively (not including `names`)."""
        return _closure(names, lambda n: self.direct(n, categories))

    def build_closure(self, name: str) -> set[str]:
        """What must be on a package's environment to build it: its build and run
        dependencies, plus the run dependencies of those, recursively (colcon's rule)."""
        known = self._closures.get(name)
        if known is None:
            known = self._closures[name] = frozenset(self._build_closure(name))
        return set(known)

    def _build_closure(self, name: str) -> set[str]:
        result: set[str] = set()
        stack = list(self.direct(name, (DepCategory.BUILD, DepCategory.RUN)))
        while stack:
            dep = stack.pop()
            if dep not in result:
                result.add(dep)
                stack.extend(self.direct(dep, (DepCategory.RUN,)))
        return result

    def reverse_edges(self) -> Mapping[str, frozenset[str]]:
        """Package -> the workspace packages depending on it directly (any category): built
        once per graph."""
        if not self._reverse and self.packages:
            reverse: dict[str, set[str]] = {n: set() for n in self.packages}
            for name in self.packages:
                for dep in self.direct(name):
                    reverse[dep].add(name)
            self._reverse.update({n: frozenset(users) for n, users in reverse.items()})
        return self._reverse

    def dependents(self, names: Iterable[str], depth: int | None = None) -> set[str]:
        """All packages that depend on `names` (any category), up to `depth` hops."""
        reverse = self.reverse_edges()
        result: set[str] = set()
        frontier = set(names)
        hops = 0
        while frontier and (depth is None or hops < depth):
            frontier = {d for n in frontier for d in reverse[n]} - result
            result |= frontier
            hops += 1
        return result - set(names)

    def topological_order(self, names: Collection[str] | None = None) -> list[str]:
        """Dependencies before dependents, ties broken by name; raise CycleError on a cycle."""
        if names is None and self._order:
            return list(self._order)
        subset = set(self.packages) if names is None else set(names)
        order, stuck = toposort({n: self.direct(n) & subset for n in subset})
        if stuck:
            raise CycleError(
                "dependency cycle: " + " → ".join(self.find_cycle(stuck)),
                hint="remove one of these dependencies (test_depend counts too)",
            )
        if names is None:
            self._order.extend(order)
        return order

    def find_cycle(self, among: set[str]) -> list[str]:
        """One cycle among `among`, as a closed walk `[a, b, c, a]`, starting at the smallest name."""
        for start in sorted(among):
            path = [start]
            on_path = {start}
            iters = [iter(sorted(self.direct(start) & among))]
            while iters:
                nxt = next(iters[-1], None)
                if nxt is None:
                    iters.pop()
                    on_path.discard(path.pop())
                    continue
                if nxt == start:
                    return [*path, start]
                if nxt not in on_path:
                    path.append(nxt)
                    on_path.add(nxt)
                    iters.append(iter(sorted(self.direct(nxt) & among)))
        return sorted(among)  # unreachable for a real cycle


def toposort(dependencies: Mapping[str, Iterable[str]]) -> tuple[list[str], set[str]]:
    """colcon's topological order: (order, names left over by a cycle).

    Kahn's algorithm by rounds, as colcon's `topological_order_packages` does: every package
    whose dependencies are all ordered joins in one round, the round sorted by name; so
    `wsbuild list -t` and --packages-start/-end agree with colcon's. Dependencies that are
    not keys of `dependencies` are ignored."""
    pending = {n: {d for d in deps if d in dependencies and d != n}
               for n, deps in dependencies.items()}
    users: dict[str, list[str]] = {n: [] for n in pending}
    for name, deps in pending.items():
        for dep in deps:
            users[dep].append(name)
    ready = sorted(n for n, deps in pending.items() if not deps)
    order: list[str] = []
    while ready:
        order += ready
        following: list[str] = []
        for name in ready:
            for user in users[name]:
                pending[user].discard(name)
                if not pending[user]:
                    following.append(user)
        ready = sorted(following)
    return order, set(pending) - set(order)


def _closure(names: Iterable[str], step: Callable[[str], set[str]]) -> set[str]:
    start = set(names)
    seen: set[str] = set()
    stack = list(start)
    while stack:
        for dep in step(stack.pop()):
            if dep not in seen:
                seen.add(dep)
                stack.append(dep)
    return seen - start


def build_graph(packages: Mapping[str, Package]) -> Graph:
    """Edges among workspace packages; `group_depend` expands to the group's members."""
    groups: dict[str, set[str]] = {}
    for package in packages.values():
        for group in package.member_of_groups:
            groups.setdefault(group, set()).add(package.name)
    kind_categories = {
        kind: [c for c in ALL_CATEGORIES if kind in CATEGORY_KINDS[c]] for kind in DepKind
    }
    edges: dict[str, dict[DepCategory, frozenset[str]]] = {}
    for name, package in packages.items():
        per_category: dict[DepCategory, set[str]] = {c: set() for c in ALL_CATEGORIES}
        for dep in package.dependencies:
            if dep.kind is DepKind.GROUP:
                targets = groups.get(dep.name, set()) - {name}
            elif dep.name in packages and dep.name != name:
                targets = {dep.name}
            else:
                continue
            for category in kind_categories[dep.kind]:
                per_category[category] |= targets
        edges[name] = {c: frozenset(deps) for c, deps in per_category.items()}
    return Graph(packages=packages, edges=edges)

"""The plan as `build --dry-run` shows it: lines for people, JSON for tools."""

from __future__ import annotations

import os

from wsbuild.builder.overrides import override_warning
from wsbuild.builder.plan import BuildPlan, Decision, PackagePlan
from wsbuild.words import plural


def plan_lines(build_plan: BuildPlan) -> list[str]:
    """The plan as a person reads it."""
    packages = build_plan.packages
    building = build_plan.to_do()
    lines = [f"dry run: {plural(len(packages), 'package')}, "
             f"{len(building)} would build, {len(packages) - len(building)} up to date "
             "(nothing was touched)"]
    width = max((len(p.name) for p in packages), default=0)
    digits = len(str(len(packages)))
    for number, package in enumerate(packages, start=1):
        what = _what(package)
        lines.append(f"  {number:>{digits}}. {package.name.ljust(width)}  {what}")
    if build_plan.critical_path:
        lines.append(f"critical path (about {build_plan.critical_seconds:.0f} s of the last "
                     f"recorded or estimated durations): {' → '.join(build_plan.critical_path)}")
    if build_plan.unresolved:
        lines.append("unresolved build dependencies (the build warns and goes on; "
                     "--strict-dependencies refuses):")
        lines += [f"  {name}: {', '.join(deps)}" for name, deps in build_plan.unresolved.items()]
    if build_plan.overrides:
        lines += ["warning: " + override_warning(build_plan.overrides)]
    lines += [f"note: {text}" for text in build_plan.notices]
    if build_plan.refusal:
        lines.append(f"the build would refuse to start: {build_plan.refusal.summary}")
    return lines


def plan_json(build_plan: BuildPlan) -> dict[str, object]:
    """The plan for tools (`--dry-run --json`)."""
    return {
        "packages": [
            {
                "name": p.name,
                "build_type": p.build_type,
                "up_to_date": p.decision is Decision.UP_TO_DATE,
                "decision": p.decision.value,
                "note": p.note or None,
                "reason": None if p.reason is None else {
                    "kind": p.reason.kind, "text": p.reason.text,
                    "details": list(p.reason.details),
                    # built only if what it read of those dependencies changes (cutoff)
                    "cutoff": p.reason.cutoff,
                },
            }
            for p in build_plan.packages
        ],
        "critical_path": {"packages": list(build_plan.critical_path),
                          "seconds": round(build_plan.critical_seconds, 3)},
        "unresolved": {name: list(deps) for name, deps in build_plan.unresolved.items()},
        "not_built": {name: list(users) for name, users in build_plan.not_built.items()},
        "overrides": [{"package": o.package, "prefix": os.fspath(o.prefix),
                       "users": list(o.users)} for o in build_plan.overrides],
        "refusal": build_plan.refusal.summary if build_plan.refusal else None,
        "notices": list(build_plan.notices),
    }


def _what(package: PackagePlan) -> str:
    if package.reason is None:
        return f"up to date: {package.note}" if package.note else "up to date"
    if package.decision is Decision.RESTORE:
        return f"restore from cache: {package.reason.text}"
    return f"build: {package.reason.text}"

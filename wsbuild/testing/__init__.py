"""`wsbuild test` and `wsbuild test-result`: running pytest and CTest per package (`runners`)
and reading/writing JUnit results (`junit`).
May use: build, build_types, prefix, underlay, workspace, events, errors.
"""

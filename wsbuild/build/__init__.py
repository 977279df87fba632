"""`wsbuild build`: the stage list (`pipeline`), the scheduler (`schedule`), child processes
(`process`), up-to-date checks (`fingerprint`), the workspace lock (`lock`), log folders
(`logs`) and the run's request records (`request`).
May use: build_types, prefix, underlay, cache, workspace, events, errors.
"""

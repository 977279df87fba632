"""The test suite's oracles of a build: what each step really read (step_trace.py, with
WSBUILD_STEP_TRACE set) against what the package's record holds. Off in a user's run. Nothing
here imports the rest of builder/."""

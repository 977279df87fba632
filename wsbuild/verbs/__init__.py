"""One module per group of verbs: argument handling stays in cli.py, work happens here.
May use: every room below (build, testing, create, build_types, prefix, underlay, cache,
workspace), options and report; never cli.py.
"""

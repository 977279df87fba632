"""One module per group of verbs: each owns its arguments (`add_arguments`), their conversion
into a frozen request (the `*_from_args` functions, called once at the verb's entry: nothing
below the entry sees argparse's namespace; tests/test_layering.py checks), and the run of its
work. An option is declared by the module that uses it. `arguments.py` holds the options
several verbs share, `defaults.py` colcon-defaults' files, `load.py` the shared front half.
May use: every room below (builder, testing, create, build_types, prefix, underlay, cache,
engine, workspace) and report; never cli.py.
"""

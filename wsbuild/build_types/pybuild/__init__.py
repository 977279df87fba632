"""The Python machinery the `ament_python` and `python` build types share: reading setup.py
through a helper process (`setup_py`, `setup_py_helper`), PEP 517 builds (`pep517`,
`pep517_hook`), installing wheels and symlink installs (`install`), and install paths (`paths`).
Not named `python/`: that name is the `python` build type's module. May use: workspace, errors.
"""

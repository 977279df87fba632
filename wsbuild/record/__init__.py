"""A package's record: everything that decided its last build's output, written once after the
build (record/model.py), its own files (record/own_files.py), what it read outside
(record/outside.py), the environment it saw (record/environment.py), and the one dirty check
every shortcut asks (record/dirty.py)."""

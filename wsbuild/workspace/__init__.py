"""What is on disk and what it means: the workspace root (`root`), package discovery
(`discover`), package.xml (`manifest`, `condition`), the records (`model`), the dependency
graph (`graph`), package selection (`selection`) and where dependencies come from (`resolve`).
May use: errors. Everything else builds on this room.
"""

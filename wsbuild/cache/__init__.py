"""The shared build cache: a successful package's install, packed and stored by its cache key,
locally (~/.cache/wsbuild) and on an HTTP cache server (bazel-remote layout), and restored
instead of building. Never trusted, never blocking. May import only errors and workspace.
"""

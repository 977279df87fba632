"""`python -m wsbuild` entry point."""

from wsbuild.cli import main

raise SystemExit(main())

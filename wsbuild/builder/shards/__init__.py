"""A build split across the jobs of a CI matrix (`build --shard K/N`, `--assemble N`): the
split itself, pure logic (split.py); the times it is balanced on, fixed for the run, and the
assembling job's check (cover.py); one shard's run around the plan, with the build cache's
shared documents and waits it uses (run.py)."""

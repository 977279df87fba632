"""One module per group of verbs: argument handling stays in cli.py, work happens here."""

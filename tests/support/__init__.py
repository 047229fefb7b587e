"""Helpers the tests share: running the command (command.py, the one entry point; forked.py behind it),
mesh facts, generated scans, the real window."""

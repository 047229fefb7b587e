"""Helpers the tests share: mesh facts, hostile-input runners, generated scans, the real window."""

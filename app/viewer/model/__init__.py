"""The viewer's state without GL: nothing here imports moderngl (tests/viewer/test_model.py checks)."""

"""The viewer's state without GL: nothing here imports moderngl (tests/viewer/model/test_model.py checks)."""

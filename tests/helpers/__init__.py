"""Helpers shared by the tests (imported as ``tests.helpers.<module>``; fixtures come through
``pytest_plugins`` in ``tests/conftest.py``)."""

"""The mgdata test suite (a package: helpers in tests/helpers, fixtures through pytest_plugins)."""

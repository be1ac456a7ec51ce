"""Test-suite plugins: pytest's own ``pytester`` (the gflat pytest plugin is tested with it)."""

pytest_plugins = ["pytester"]

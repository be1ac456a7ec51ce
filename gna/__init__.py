"""gna package."""

"""The package version (kept apart so that stages can name it without importing the package root)."""

__version__ = "0.1.0"

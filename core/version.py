"""The package version, in one place (the result, project and export files record it)."""

__version__ = "0.1.0"

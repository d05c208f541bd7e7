"""The package version, in a module of its own so that any module can read it without importing the
package's public API (fem_pendulum_fmu/__init__.py)."""

__version__ = "0.1.0"

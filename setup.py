"""The compiled core's extension module; everything else about the package is in pyproject.toml."""

from setuptools import setup

setup(cffi_modules=["fem_pendulum_fmu/physics/core/cffi_build.py:ffibuilder"])

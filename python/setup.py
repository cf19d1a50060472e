# SPDX-License-Identifier: Apache-2.0
# Build: pip install ./python  (or pip wheel ./python); see python/README.md.
from setuptools import setup

setup(cffi_modules=["build_clvox.py:ffibuilder"])

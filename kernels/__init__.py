"""OpenCL C sources of pyshadow (installed as ``pyshadow.kernels``).

The ``.cl`` and ``.h`` files here are loaded by :mod:`pyshadow._cl`; this file
only makes the folder an importable package so :mod:`importlib.resources` can
find them in an installed copy.
"""

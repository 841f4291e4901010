"""``python -m pyshadow.bench``: the ``pyshadow-bench`` command."""
import sys

from .cli import main

sys.exit(main())

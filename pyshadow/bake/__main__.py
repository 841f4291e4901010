"""``python -m pyshadow.bake``: the ``pyshadow-bake`` command."""
import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())

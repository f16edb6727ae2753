"""``python -m lidartrees_gis.cli``: the ``lidartrees`` command."""
import sys

from .app import main

sys.exit(main())

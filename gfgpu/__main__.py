"""``python -m gfgpu``: the ``gfgpu`` command."""

import sys

from .cli import main

sys.exit(main())

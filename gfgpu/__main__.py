"""``python -m gfgpu``: the ``gfgpu`` command."""

import sys

try:
    # importing the command line is start-up: a Ctrl-C here is answered like one during the work
    from .cli import main
except KeyboardInterrupt:
    print("gfgpu: interrupted", file=sys.stderr)
    sys.exit(130)

sys.exit(main())

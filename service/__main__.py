"""``python -m service``: the ``meshservice`` command."""

import sys

from service.cli import main

sys.exit(main())

"""``python -m rallysim.cli``: the ``rallysim`` command."""

import sys

from rallysim.cli import main

sys.exit(main())

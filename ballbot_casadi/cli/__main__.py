"""``python -m ballbot_casadi.cli``: the ``ballbot`` console script."""

import sys

from ballbot_casadi.cli import main

sys.exit(main())

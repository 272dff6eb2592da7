"""``python -m contactrig``: the same as the ``contactrig`` console script."""

import sys

from contactrig.cli.main import main

sys.exit(main())

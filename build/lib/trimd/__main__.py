"""``python -m trimd``: the ``trimd`` command."""

import sys

from trimd.cli.main import main

sys.exit(main())

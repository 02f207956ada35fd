"""``python -m granpack.cli``: the ``granpack`` command."""

import sys

from . import main

sys.exit(main())

"""``python -m flatweave.app``: the window (as the ``flatweave`` command)."""

import sys

from flatweave.app.main import main

sys.exit(main())

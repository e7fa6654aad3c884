"""``python -m flatweave``: the headless CLI."""

import sys

from flatweave.cli import main

sys.exit(main())

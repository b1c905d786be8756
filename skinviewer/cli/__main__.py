"""``python -m skinviewer.cli``: the same as the ``skinviewer`` command."""
import sys

from skinviewer.cli import main

sys.exit(main())

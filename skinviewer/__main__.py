"""``python -m skinviewer``: the same as the ``skinviewer`` command (skinviewer/launch.py: the viewer's
window opens before its modules load)."""
import sys

from skinviewer.launch import main

sys.exit(main())

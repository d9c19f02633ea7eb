"""``python -m optdesign``: the optdesign command."""
import sys

from .cli import main

sys.exit(main())

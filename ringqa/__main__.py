"""``python -m ringqa`` runs the command line."""

import sys

from ringqa.cli import main

sys.exit(main())

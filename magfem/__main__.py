"""``python -m magfem`` = the ``magfem`` command."""

import sys

from magfem.cli import main

sys.exit(main())

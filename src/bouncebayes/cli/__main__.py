"""``python -m bouncebayes.cli``: the same as the ``bouncebayes`` command."""

import sys

from ._app import main

sys.exit(main())

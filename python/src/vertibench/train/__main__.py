"""``python -m vertibench.train rl|mcl|acl ...`` (see :mod:`vertibench.train.cli`)."""

import sys

from .cli import main

sys.exit(main())

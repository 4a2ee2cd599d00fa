import sys

from mound.cli import main

sys.exit(main())

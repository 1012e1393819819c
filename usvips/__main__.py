import sys

from usvips.cli import main

sys.exit(main())

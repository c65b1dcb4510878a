"""`python -m iguana_ros.cli` runs the `iguana` command."""
import sys

from iguana_ros.cli import main

sys.exit(main())

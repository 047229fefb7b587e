"""`python -m isoscope` is the `isoscope` command."""
import sys

from .cli import main

sys.exit(main())

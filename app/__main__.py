"""`python -m isoscope` is the `isoscope` command."""
import sys

from .launch import main

sys.exit(main())

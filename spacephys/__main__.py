"""`python -m spacephys ...` is the `spacephys` command."""
import sys

from .cli import main

sys.exit(main())

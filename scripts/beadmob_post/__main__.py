"""``python -m beadmob_post``: same as the ``beadmob-post`` command."""

import sys

from beadmob_post.cli import main

if __name__ == "__main__":
    sys.exit(main())

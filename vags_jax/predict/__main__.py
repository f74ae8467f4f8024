"""``python -m vags_jax.predict``: ``vags_jax.predict.commands``."""
import sys

from vags_jax.predict.commands import main

sys.exit(main())

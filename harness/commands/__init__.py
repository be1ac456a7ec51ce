"""Sub-commands of the ``gflat`` tool (one module each, with ``register(subparsers)``)."""

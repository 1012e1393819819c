"""One module per model family (see :mod:`usvips.core.detection.registry`)."""

"""One module per housing kind; each defines one :class:`~usvips.core.housing.base.Housing` subclass
with a ``kind`` name, which registers it (``usvips/core/housing/registry.py``)."""

"""One module per measurement kind; the registry (``usvips.core.measurements.registry``) imports them all.
To add a kind, add a module here defining a :class:`~usvips.core.measurements.registry.MeasurementKind`
subclass with a ``name``, and its test."""

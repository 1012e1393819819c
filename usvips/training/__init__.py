"""Development tools that make USVIPS's shipped models (PyTorch, the ``train`` extra); never imported at
run time."""

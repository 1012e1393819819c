"""The figures child process (:mod:`usvips.gui.figures_process`): ``python -m usvips.gui.figures_child``.

A module of its own so that the requests are served by ``usvips.gui.figures_process`` imported under its
name: run as ``-m`` itself, that file would be ``__main__``, whose classes are not the ones the requests'
pickles name.
"""

from usvips.gui.figures_process import serve_stdio

if __name__ == "__main__":
    serve_stdio()

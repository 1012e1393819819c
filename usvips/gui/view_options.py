"""The choices the image panes offer, as plain data (the panes in :mod:`usvips.gui.qt.pane` draw them; the
declared commands in :mod:`usvips.gui.commands` list them in the View menu)."""

#: magnifications of the loupe (screen pixels per image pixel)
LOUPE_SCALES = (4, 8, 12, 16)

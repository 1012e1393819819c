"""The window's dialogs, tools and controllers take what they need (the window's context: the workspace, the
messages, the worker, what the window may be asked to show; a parent widget), never the window: a scan of
their source for a parameter named ``window``, a ``window.…`` or ``….window_`` reach-in, or an import of the
main window. Only the modules that build, register or drive the window itself may hold it."""

import ast
from pathlib import Path

import usvips.gui.qt

QT_FOLDER = Path(usvips.gui.qt.__file__).parent

#: the modules that are about the window itself, each with why it holds it
WINDOW_LEVEL = {
    "main_window.py": "the window",
    "app.py": "starts the window",
    "error_report.py": "shows an uncaught error in the registered window",
    "menu_keys.py": "installs its key filter on the window's menus",
    "opening_probe.py": "times the window opening (bench)",
    "ready.py": "says when the window is ready to use (bench and start-up)",
    "bench.py": "drives a window to time it",
    "bench_detection.py": "drives a window to time it",
    "bench_live.py": "drives a window to time it",
    "bench_object_list.py": "drives a window to time it",
    "bench_tracking.py": "drives a window to time it",
    "live_updates.py": "colleagues' changes shown across the window's status bar, list, form and log",
}


def reach_ins(source: str) -> list[str]:
    """Where ``source`` takes or reaches into the window: (line: what) for each."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.arg) and node.arg in ("window", "main_window"):
            found.append(f"{node.lineno}: a parameter named {node.arg!r}")
        elif isinstance(node, ast.arg) and node.annotation is not None and "MainWindow" in ast.unparse(node.annotation):
            found.append(f"{node.lineno}: a parameter typed {ast.unparse(node.annotation)}")
        elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "window":
            found.append(f"{node.lineno}: window.{node.attr}")
        elif isinstance(node, ast.Attribute) and node.attr in ("window_", "main_window"):
            found.append(f"{node.lineno}: .{node.attr}")
        elif isinstance(node, ast.ImportFrom) and (node.module or "").endswith("main_window"):
            found.append(f"{node.lineno}: imports {node.module}")
    return found


def test_the_scan_finds_each_kind_of_reach_in():
    source = ("from usvips.gui.qt.main_window import MainWindow\n"
              "def f(window): window.show_message('info', 'x')\n"
              "def g(host: 'MainWindow'): pass\n"
              "class D:\n    def go(self): self.window_.workspace.project\n")
    assert len(reach_ins(source)) == 5
    assert reach_ins("def f(context, parent): context.messages.info('x')\n") == []


def test_no_dialog_or_controller_takes_the_window():
    modules = sorted(QT_FOLDER.glob("*.py"))
    assert {"media_dialogs.py", "exchange_dialogs.py", "pointing_test_dialog.py", "double_read_dialog.py",
            "target_field_tool.py"} <= {m.name for m in modules}
    found = {m.name: reach_ins(m.read_text(encoding="utf-8")) for m in modules if m.name not in WINDOW_LEVEL}
    assert {name: lines for name, lines in found.items() if lines} == {}
    assert set(WINDOW_LEVEL) <= {m.name for m in modules}, "a window-level module named here no longer exists"

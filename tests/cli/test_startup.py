"""``usvips --help`` imports no subcommand's module (their numpy, OpenCV and SciPy cost over 0.5 s of CPU):
the overview lists them by their summaries, which must stay the modules' own help lines; a subcommand
still gets its full parser. (Its CPU time is a row of ``usvips bench --only startup``, not a timed test.)"""

import os
import subprocess
import sys

import pytest

from usvips.cli import (
    BLAS_SPIN_LOG2_CYCLES,
    BLAS_SPIN_VARIABLE,
    COMMANDS,
    EXTENDS,
    SUMMARIES,
    brief_blas_spin,
    build_parser,
    main,
)


def _helps(parser) -> dict[str, str]:
    action = next(a for a in parser._actions if a.dest == "command")
    return {choice.dest: choice.help for choice in action._choices_actions}


def test_the_overview_summaries_are_the_subcommands_own_help():
    assert set(SUMMARIES) == set(COMMANDS) - set(EXTENDS)
    assert _helps(build_parser("*")) == SUMMARIES
    assert _helps(build_parser(None)) == SUMMARIES


def test_the_overview_imports_no_subcommand_and_no_numpy():
    code = ("import sys\nfrom usvips.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in sys.modules if m.startswith('usvips.cli.') or m.split('.')[0] in "
            "{'numpy', 'cv2', 'scipy', 'PySide6'}), file=sys.stderr)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stderr.strip().splitlines()[-1] == "[]"
    for name in SUMMARIES:
        assert name in result.stdout


@pytest.mark.parametrize("command", ["project", "video", "intersect"])
def test_a_subcommand_gets_its_full_parser_and_only_its_module(command, capsys):
    assert main([command, "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usvips: error") is False and f"usvips {command}" in out
    parser = build_parser(command)
    assert _helps(parser)[command] == SUMMARIES[command]


def test_a_module_that_extends_a_command_comes_with_it(capsys):
    assert main(["video", "calibration-views", "--help"]) == 0
    assert "--max-views" in capsys.readouterr().out


@pytest.mark.parametrize("action", ["", "info", "add-video", "check", "push", "set-metadata"])
def test_the_project_command_parses_without_numpy_scipy_opencv_or_pyav(action):
    """``usvips project [ACTION] --help`` builds the whole project parser (every action registered) and
    loads none of the work: each handler imports it when it runs."""
    argv = ["project", *([action] if action else []), "--help"]
    code = (f"import sys\nfrom usvips.cli import main\nassert main({argv!r}) == 0\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in {'numpy', 'cv2', 'scipy', 'av', 'PySide6'}"
            " or m.startswith(('usvips.store', 'usvips.app'))), file=sys.stderr)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stderr.strip().splitlines()[-1] == "[]"
    assert f"usvips project {action}".strip() in result.stdout


def test_openblas_threads_busy_wait_briefly_unless_the_user_set_how_long(monkeypatch):
    monkeypatch.delenv(BLAS_SPIN_VARIABLE, raising=False)
    brief_blas_spin()
    assert os.environ[BLAS_SPIN_VARIABLE] == str(BLAS_SPIN_LOG2_CYCLES) == "20"  # OpenBLAS's default is 28
    monkeypatch.setenv(BLAS_SPIN_VARIABLE, "28")
    brief_blas_spin()
    assert os.environ[BLAS_SPIN_VARIABLE] == "28"


def test_the_brief_spin_is_set_before_a_command_loads_numpy():
    """OpenBLAS reads its variables when it is loaded (with numpy): a command whose module imports numpy
    finds the variable already set."""
    code = (f"import os, sys\nos.environ.pop({BLAS_SPIN_VARIABLE!r}, None)\nseen = []\n"
            "class Spy:\n    def find_spec(self, name, path=None, target=None):\n"
            "        if name == 'numpy' and not seen:\n"
            f"            seen.append(os.environ.get({BLAS_SPIN_VARIABLE!r}))\n"
            "sys.meta_path.insert(0, Spy())\nfrom usvips.cli import main\n"
            "try:\n    main(['intersect', '--help'])\nexcept SystemExit:\n    pass\n"
            "print(seen, file=sys.stderr)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stderr.strip().splitlines()[-1] == f"[{str(BLAS_SPIN_LOG2_CYCLES)!r}]"

"""Options read as other programs write numbers: digit separators and other scripts' digits are refused."""

import argparse

import pytest

from usvips.cli import main, plain_float, whole_number


@pytest.mark.parametrize("text", ["1_000", "١٢", "１２", "٣.٥"])
def test_a_float_option_refuses_what_other_programs_read_as_text(text):
    with pytest.raises(argparse.ArgumentTypeError, match="is not a number"):
        plain_float(text)


def test_whole_numbers_and_every_float_option_read_plain_numbers(capsys):
    assert whole_number("42") == 42
    for text in ("4_2", "٤٢"):
        with pytest.raises(argparse.ArgumentTypeError):
            whole_number(text)
    # a float option of a command (its type=float read by plain_float): refused in one line, exit 2
    assert main(["calibrate", "--help"]) == 0 and capsys.readouterr()
    assert main(["bench", "--scale", "1_0"]) == 2
    assert "argument --scale: '1_0' is not a number" in capsys.readouterr().err

"""Numbers as other programs write them: digit separators and other scripts' digits are text."""

import pytest

from usvips.core.plain_numbers import plain_number


@pytest.mark.parametrize("text", ["1_000", "١٢", "１２", "1_0.5", "٣.٥", "1e1_0"])
def test_what_python_reads_but_other_programs_do_not_is_refused(text):
    with pytest.raises(ValueError):
        plain_number(text)


@pytest.mark.parametrize(("text", "value"), [("12", 12.0), ("-3.5", -3.5), ("1e3", 1000.0), (" 7 ", 7.0),
                                             ("nan", None), ("+0.25", 0.25)])
def test_plain_numbers_read_as_float_does(text, value):
    number = plain_number(text)
    assert (value is None and number != number) or number == value

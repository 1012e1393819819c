"""An error worded in a form's terms (usvips.gui.field_errors, Qt-free): the parameter it carries names a
field of the form, and the message names the field's label instead of the library's name."""

from usvips.core.errors import InvalidParameterError, UsvipsError, concerning
from usvips.gui.field_errors import field_error
from usvips.gui.housing_values import known_label, read_known

LABELS = {"tolerance_s": "Same instant within", "readers": "Reader &B:"}


def test_an_error_naming_a_field_is_worded_with_its_label():
    found = field_error(InvalidParameterError("tolerance_s", "must be ≥ 0, got -1"), LABELS)
    assert (found.parameter, found.label, found.text) == ("tolerance_s", "Same instant within",
                                                          "Same instant within: must be ≥ 0, got -1")
    marked = field_error(concerning(UsvipsError("give two different annotators"), "readers"), LABELS, "report: ")
    assert marked.text == "report: Reader B: give two different annotators"  # no mnemonic, no colon


def test_an_error_naming_no_field_of_the_form_is_left_to_be_said_as_it_is():
    assert field_error(InvalidParameterError("gate_m", "must be > 0"), LABELS) is None
    assert field_error(UsvipsError("the project is read-only"), LABELS) is None


def test_typed_housing_values_name_their_symbol_when_bad():
    assert read_known("flat-port", {"t": "0.012", "n2": "1.5 ± 0.01", "g": " "}) == {"t": (0.012, None),
                                                                                    "n2": (1.5, 0.01)}
    for texts, symbol, words in (({"t": "-0.002"}, "t", "must be > 0 m, got -0.002"),
                                 ({"n2": "0.9"}, "n2", "must be > 1"),
                                 ({"g": "five"}, "g", "type a value (fixed) or 'value ± sigma'"),
                                 ({"n3": "1.34 ± 0"}, "n3", "its sigma must be a positive number"),
                                 ({"r": "nan"}, "r", "must be a finite number")):
        housing = "dome-port" if symbol == "r" else "flat-port"
        try:
            read_known(housing, texts)
        except InvalidParameterError as error:
            assert error.parameter == symbol and words in error.problem, (texts, error)
        else:
            raise AssertionError(f"{texts} accepted")
    assert known_label("flat-port", "t") == "housing value t (m)"
    assert known_label("flat-port", "n2") == "housing value n2 (no unit)"

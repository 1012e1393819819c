"""Usage errors are one short line: an unquoted pattern the shell expanded is named as such, not listed."""

from usvips.cli import main


def test_an_expanded_pattern_is_counted_and_named_not_listed(tmp_path, capsys):
    files = [str(tmp_path / f"left{k:02d}.png") for k in range(40)]
    code = main(["calibrate", "air", "--left-images", *files, "--right-images", "r.png", "--target", "t.json",
                 "--out", str(tmp_path / "o.json")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "39 unrecognized arguments" in err and "(36 more)" in err and "quote it" in err
    assert files[-1] not in err and err.count(".png") == 4  # the first three, and the hint's '*.png'


def test_a_few_unknown_words_are_shown_as_they_are(capsys):
    code = main(["plan", "--nope", "x"])
    err = capsys.readouterr().err
    assert code == 2 and "unrecognized arguments: --nope x" in err and "quote it" not in err

"""The shared core of robocal.io.programs: numbers written back as the file wrote them,
robocal's comment line and its recogniser, the language by extension, the file's bytes and
line endings kept."""
import pytest

from robocal.errors import InputError
from robocal.io.programs import krl, language_of, rapid, urscript
from robocal.io.programs.core import (
    MARK,
    Number,
    ProgramFile,
    format_like,
    is_filtered,
    rewrite,
    strip_comments,
)


@pytest.mark.parametrize("original, value, decimals, written", [
    ("1200.5", 1200.5 + 1e-9, 4, "1200.5"),        # unchanged at the precision written: the same characters
    ("1200.5", 1200.5371, 4, "1200.5371"),          # finer than the file, never coarser
    ("-0.123456", -0.1234561, 4, "-0.123456"),      # already finer: kept when it does not move
    ("-0.123456", -0.1239, 4, "-0.123900"),         # the file's own precision when finer than the minimum
    ("+90", 90.25, 4, "+90.2500"),                  # a leading '+' stays
    ("0.0", -1e-9, 4, "0.0"),
    ("0.0", -0.00002, 4, "0.0"),                    # below half the last decimal written: unchanged
    ("0.0", -0.0004, 4, "-0.0004"),
    ("9E+02", 900.00001, 4, "9E+02"),
    ("1.5e1", 15.123, 4, "15.1230"),
])
def test_numbers_keep_their_characters_or_precision(original, value, decimals, written):
    assert format_like(value, Number(0, original), decimals) == written


def test_decimals():
    assert Number(0, "12").decimals == 0 and Number(0, "1.250").decimals == 3
    assert Number(0, "1.5e-3").decimals == 4 and Number(0, "9E+09").decimals == 0


@pytest.mark.parametrize("name, module", [("a.SRC", krl), ("a.dat", krl), ("m.mod", rapid), ("m.MODX", rapid),
                                          ("m.prg", rapid), ("p.script", urscript)])
def test_language_by_extension(name, module):
    assert language_of(name) is module


def test_unknown_extension_is_one_line():
    with pytest.raises(InputError, match="--language krl|rapid|urscript"):
        language_of("program.txt")
    assert language_of("program.txt", "rapid") is rapid
    with pytest.raises(InputError, match="unknown --language"):
        language_of("p.src", "fanuc")


def test_recogniser_wants_the_mark_after_the_comment_sign():
    assert is_filtered(f"MODULE M\r\n  ! {MARK} targets compensated with model m.json\r\n", "!")
    assert not is_filtered(f'MODULE M\r\n  TPWrite "{MARK}";\r\n', "!")
    assert not is_filtered("; robocal was here\n", ";")


def test_rewrite_keeps_line_endings_and_inserts_one_line():
    text = "&ACCESS RVP\r\nDEF a( )\r\nPTP {X 1.5,Y 2}\r\nEND\r\n"
    program = ProgramFile("a.src", text, krl.NAME)
    at = text.index("1.5")
    written = rewrite(program, [(Number(at, "1.5"), "1.5250")], krl.comment_offset(text), "; robocal filter: x")
    assert written == "&ACCESS RVP\r\n; robocal filter: x\r\nDEF a( )\r\nPTP {X 1.5250,Y 2}\r\nEND\r\n"


def test_comments_are_blanked_in_place():
    text = 'PTP XP1 ; PTP {X 1}\r\nMSG = "; not a comment" ; but this is\r\n'
    stripped = strip_comments(text, ";")
    assert len(stripped) == len(text) and "X 1" not in stripped and '"; not a comment"' in stripped
    assert stripped.count("\r\n") == 2


def test_a_failed_write_leaves_no_new_file(tmp_path, monkeypatch):
    from robocal.interfaces import filter as job

    calls = []

    def failing(path, text, encoding="utf-8"):
        calls.append(path)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        (tmp_path / path).write_text(text)

    monkeypatch.setattr(job, "write_text_atomic", failing)
    with pytest.raises(OSError):
        job._write_all([(tmp_path / "a.src", "x"), (tmp_path / "a.dat", "y"), (tmp_path / "s.csv", "z")])
    assert not list(tmp_path.iterdir())

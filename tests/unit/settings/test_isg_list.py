"""ISG ASCII list syntax (docs/reference/isg-cnc.md §3.1) on golden files and edge cases."""

from __future__ import annotations

from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

from liftd.settings.isg_list import Severity, parse_list_text, parse_number, read_list
from liftd.settings.isg_schema import CHANNEL_KEYS, type_list
from tests.support.paths import GOLDEN


def test_golden_syntax_sample_reads_every_rule() -> None:
    parsed = read_list(GOLDEN / "lists" / "syntax.lis")
    assert parsed.problems == ()
    values, problems = type_list(parsed, CHANNEL_KEYS)
    assert problems == []
    got = {key: v.value for key, v in values.items()}
    assert got["lift_min_dist"] == 50000
    assert got["enable_time_based_lift"] is True
    assert got["max_radius_diff_circle"] == 0x32
    assert got["gruppe[0].achse[0].bezeichnung"] == "X"
    assert got["gruppe[0].achse[0].log_achs_nr"] == 1
    assert got["gruppe[0].bezeichnung"] == "Bahn (main)"
    assert got["configuration.path_preparation.function"] == {"FCT_DEFAULT", "FCT_LIFT_UP_TIME"}
    assert got["configuration.interpolator.function"] == {"FCT_IPO_DEFAULT", "FCT_LIFT_UP_TIME"}
    assert got["m_synch[4]"] == "MVS_SVS"
    assert got["m_synch[8]"] == "0x8"
    assert got["prog_start.slope.profile"] == 0
    # line numbers are kept for messages
    assert values["lift_min_dist"].entry.line == 5


def test_a_list_saved_as_utf8_with_a_byte_order_mark_reads_like_without(tmp_path: Path) -> None:
    plain = GOLDEN / "lists" / "syntax.lis"
    bom = tmp_path / "syntax.lis"
    bom.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    parsed = read_list(bom)
    assert parsed.problems == ()
    expected = read_list(plain).entries
    assert [(e.key, e.value, e.line) for e in parsed.entries] == [
        (e.key, e.value, e.line) for e in expected
    ]
    _, problems = type_list(parsed, CHANNEL_KEYS)
    assert problems == []


def test_hash_without_blank_is_not_a_comment_but_an_unknown_key() -> None:
    parsed = parse_list_text("#lift_min_dist 5\n", "a.lis")
    _, problems = type_list(parsed, CHANNEL_KEYS)
    assert [p.severity for p in problems] == [Severity.ERROR]
    assert "malformed key" in problems[0].message


def test_string_comment_needs_parenthesis() -> None:
    parsed = parse_list_text("gruppe[0].bezeichnung Bahn # not a comment\n", "a.lis")
    assert parsed.entries[0].value == "Bahn # not a comment"


def test_unknown_key_is_a_warning_with_location() -> None:
    parsed = parse_list_text("\n\nfoo.bar 3\n", "chan.lis")
    _, problems = type_list(parsed, CHANNEL_KEYS)
    assert len(problems) == 1
    p = problems[0]
    assert (p.severity, p.file, p.line, p.key, p.value) == (
        Severity.WARNING,
        "chan.lis",
        3,
        "foo.bar",
        "3",
    )
    assert str(p) == "chan.lis:3: foo.bar = '3' warning: unknown parameter, ignored"


def test_missing_value_unterminated_quote_and_bad_types_are_errors() -> None:
    text = (
        "lift_min_dist\n"
        'gruppe[0].bezeichnung "open\n'
        "lift_min_dist abc\n"
        "enable_time_based_lift 2\n"
        "lift_min_dist -1\n"
        "configuration.interpolator.function FCT_IPO_DEFAULT | FCT_BOGUS\n"
        "configuration.path_preparation.function FCT_DEFAULT ||\n"
    )
    _, problems = type_list(parse_list_text(text, "c.lis"), CHANNEL_KEYS)
    msgs = [(p.line, p.message) for p in problems]
    assert msgs[0] == (1, "missing value")
    assert msgs[1] == (2, "unterminated quoted string")
    assert msgs[2] == (3, "expected an integer")
    assert msgs[3] == (4, "expected a boolean 0 or 1")
    assert msgs[4][0] == 5 and msgs[4][1].startswith("out of range")
    assert msgs[5][0] == 6 and "unknown flag 'FCT_BOGUS'" in msgs[5][1]
    assert msgs[6] == (7, "empty flag in a '|'-joined flag set")
    assert all(p.severity is Severity.ERROR for p in problems)


def test_duplicate_key_warns_and_last_wins() -> None:
    values, problems = type_list(
        parse_list_text("lift_min_dist 1\nlift_min_dist 2\n", "c.lis"), CHANNEL_KEYS
    )
    assert values["lift_min_dist"].value == 2
    assert "first at line 1" in problems[0].message


def test_numbers() -> None:
    assert parse_number("0x1F") == 31
    assert parse_number("-12") == -12
    assert parse_number("007") == 7
    assert parse_number("1.5e3") == 1500.0
    assert parse_number("1.2.3") is None
    assert parse_number("X") is None


@given(st.text())
def test_any_text_gives_entries_or_problems_never_an_exception(text: str) -> None:
    parsed = parse_list_text(text, "fuzz.lis")
    values, problems = type_list(parsed, CHANNEL_KEYS)
    assert all(p.file == "fuzz.lis" for p in problems)
    assert set(values) <= {e.key for e in parsed.entries}

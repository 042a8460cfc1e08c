"""Tags: the ROS 2 topic-name rules, and a deterministic mapping of any string to a valid tag."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from dbglog._ros._tags import MAX_TOPIC_LENGTH, TagError, sanitize_tag, tag_problem, topic_for_tag

VALID = ["x", "proximity", "arm/joint_1", "a/b/c", "_1", "A_b9", "x" * (MAX_TOPIC_LENGTH - 14)]
INVALID = {
    "": "empty",
    " ": "not allowed",
    "a-b": "not allowed",
    "1abc": "digit",
    "~": "not allowed",
    "{x}": "not allowed",
    "a//b": "//",
    "/a": "starts with",
    "a/": "ends with",
    "a/2b": "digit",
    "x" * 300: "characters long",
    "nul\x00": "not allowed",
    "ünï": "not allowed",
}


@pytest.mark.parametrize("tag", VALID)
def test_valid_tags_pass_and_map_to_themselves(tag: str) -> None:
    """A valid tag has no problem and sanitises to itself."""
    assert tag_problem(tag) is None
    assert sanitize_tag(tag) == tag


@pytest.mark.parametrize(("tag", "why"), INVALID.items())
def test_invalid_tags_name_their_problem(tag: str, why: str) -> None:
    """Each rule violation is reported with a reason."""
    problem = tag_problem(tag)
    assert problem is not None
    assert why in problem


def test_documented_examples() -> None:
    """The mappings the README promises."""
    assert sanitize_tag("a-b") == "a_b"
    assert sanitize_tag("1abc") == "_1abc"
    assert sanitize_tag("a//b") == "a/b"
    assert sanitize_tag("") == "_"
    assert topic_for_tag("arm/x") == "/rosdashboard/arm/x"


@pytest.mark.parametrize("bad", [None, 123, b"x", 1.5])
def test_non_strings_are_a_tag_error(bad: object) -> None:
    """Only strings can be sanitised."""
    with pytest.raises(TagError, match="must be a str"):
        sanitize_tag(bad)  # type: ignore[arg-type]


@given(st.text(max_size=400))
def test_sanitize_always_gives_a_valid_idempotent_tag(tag: str) -> None:
    """Any string maps to a valid tag, the mapping is stable, and valid output maps to itself."""
    clean = sanitize_tag(tag)
    assert tag_problem(clean) is None
    assert sanitize_tag(tag) == clean
    assert sanitize_tag(clean) == clean
    assert len(topic_for_tag(clean)) <= MAX_TOPIC_LENGTH

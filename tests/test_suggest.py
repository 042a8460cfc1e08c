"""Close matches and hints for topics nobody publishes (dbglog/viewer/_data/_suggest.py)."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from dbglog.viewer._data._suggest import EMPTY_GRAPH_HINT, close_matches, sub_topics, unpublished_reason

GRAPH = [
    "/rosdashboard/proximity",
    "/rosdashboard/motor/rpm",
    "/rosdashboard/motor/temp",
    "/turtle1/pose",
    "/turtle1/cmd_vel",
    "/rosout",
]


def test_typo_finds_the_real_topic() -> None:
    """A misspelled tag suggests the tag it most resembles, first."""
    assert close_matches("/rosdashboard/proximty", GRAPH)[0] == "/rosdashboard/proximity"


def test_short_typo_in_last_component() -> None:
    """A typo in the last component of a topic still finds it."""
    assert "/turtle1/pose" in close_matches("/turtle1/pse", GRAPH)


def test_unrelated_name_suggests_nothing() -> None:
    """A name like nothing on the graph gets no suggestion rather than a random one."""
    assert close_matches("/zzzzqqq", GRAPH) == []


def test_the_name_itself_is_never_suggested() -> None:
    """A topic that is on the graph is not its own close match."""
    assert "/rosout" not in close_matches("/rosout", GRAPH)


def test_sub_topics_of_a_dict_tag() -> None:
    """A dict parent lists its keys' topics, and only those."""
    assert sub_topics("/rosdashboard/motor", GRAPH) == ["/rosdashboard/motor/rpm", "/rosdashboard/motor/temp"]
    assert sub_topics("/rosdashboard/mot", GRAPH) == []


def test_reason_for_empty_graph_names_domain_and_range() -> None:
    """An empty graph points at ROS_DOMAIN_ID and the discovery range."""
    reason = unpublished_reason("/rosdashboard/x", [])
    assert reason == EMPTY_GRAPH_HINT
    assert "ROS_DOMAIN_ID" in reason
    assert "ROS_AUTOMATIC_DISCOVERY_RANGE" in reason


def test_reason_for_dict_parent_lists_sub_topics() -> None:
    """A dict parent's reason names its sub-topics."""
    reason = unpublished_reason("/rosdashboard/motor", GRAPH)
    assert "/rosdashboard/motor/rpm" in reason
    assert "/rosdashboard/motor/temp" in reason


def test_reason_for_typo_offers_the_match() -> None:
    """A typo's reason offers the close match as a question."""
    reason = unpublished_reason("/rosdashboard/proximty", GRAPH)
    assert "did you mean /rosdashboard/proximity?" in reason


def test_reason_for_unknown_name_says_not_on_graph() -> None:
    """A name with no match says plainly that nothing publishes it."""
    assert unpublished_reason("/zzzzqqq", GRAPH) == "nothing publishes /zzzzqqq (not on the ROS graph yet)"


@given(st.text(max_size=40), st.lists(st.text(max_size=40), max_size=20))
def test_close_matches_are_always_known_names(wanted: str, known: list[str]) -> None:
    """Suggestions come only from the known names, at most three, never the name itself."""
    found = close_matches(wanted, known)
    assert len(found) <= 3
    assert set(found) <= set(known) - {wanted}

"""GraphView on a real ROS graph: endpoint counts from each node's lists, and how often each read is due."""

from __future__ import annotations

import itertools
import time
from collections.abc import Iterator

import pytest
from std_msgs.msg import Float64, String

from dbglog._ros._graph import LIST_SHARE, RECOUNT_S, SETTLE_S, Endpoints, GraphView
from tests._ros import RosPeer, wait_quiet, wait_until

_ids = itertools.count()
TIMEOUT = 20.0


@pytest.fixture(scope="module")
def reader() -> Iterator[RosPeer]:
    """The node whose view of the graph is read (its own subscriptions are left out of the counts)."""
    with RosPeer("graph_reader") as peer:
        yield peer


def _own(peer: RosPeer) -> tuple[str, str]:
    return (peer.node.get_namespace(), peer.node.get_name())


def _look_until(graph: GraphView, reader: RosPeer, ok: object) -> None:
    """Look at the graph (a count every time: `now` runs a recount period ahead) until `ok()` holds."""
    assert callable(ok)
    clock = [time.monotonic()]

    def check() -> bool:
        clock[0] += RECOUNT_S
        graph.look(reader.node, clock[0], period=0.1, own_subs={"/graph_test/own_only"})
        return bool(ok())

    assert wait_until(check, TIMEOUT), f"never held: {graph.counts}"


def test_each_topic_is_counted_from_its_nodes_lists_as_rmw_counts_it(reader: RosPeer) -> None:
    """Publishers and subscribers of every topic, counted from each node's publisher and subscription lists,
    are what rmw's per-topic counts say (the reader's own subscriptions left out), with the publishing
    nodes named; a topic only the reader subscribes to has none."""
    run = next(_ids)
    both, one, subs_only = (f"/graph_test/{stem}_{run}" for stem in ("both", "one", "subs_only"))
    graph = GraphView(_own(reader))
    reader.subscribe(both, Float64)
    reader.subscribe("/graph_test/own_only", Float64)
    with RosPeer(f"graph_a_{run}") as a, RosPeer(f"graph_b_{run}") as b:
        a.publisher(both, Float64)
        a.publisher(one, String)
        a.subscribe(subs_only, String)
        b.publisher(both, Float64)
        b.subscribe(one, String)
        expected = {
            both: Endpoints(2, 0, tuple(sorted([_own(a), _own(b)]))),
            one: Endpoints(1, 1, (_own(a),)),
            subs_only: Endpoints(0, 1, ()),
            "/graph_test/own_only": Endpoints(0, 0, ()),
        }
        _look_until(graph, reader, lambda: all(graph.counts.get(t) == e for t, e in expected.items()))
        node = reader.node
        for topic in (both, one, subs_only):
            assert graph.counts[topic].publishers == node.count_publishers(topic)
            own = 1 if topic == both else 0
            assert graph.counts[topic].subscribers == node.count_subscribers(topic) - own


def test_nodes_of_one_name_have_every_topic_counted(reader: RosPeer) -> None:
    """rmw answers one node's lists for two nodes of one name: the other's topics, which no node it knows
    has, are counted by topic, so both are listed with their publisher."""
    run = next(_ids)
    first, second = f"/graph_test/twin_first_{run}", f"/graph_test/twin_second_{run}"
    graph = GraphView(_own(reader))
    with RosPeer(f"graph_twin_{run}") as one, RosPeer(f"graph_twin_{run}") as other:
        one.publisher(first, Float64)
        other.publisher(second, Float64)
        nobody = Endpoints(0, 0, ())

        def both_counted() -> bool:  # (an endpoint can show before rmw knows its node: by topic, then)
            ends = [graph.counts.get(t, nobody) for t in (first, second)]
            by = sorted((e.by for e in ends), key=lambda b: b is None)
            return all(e.publishers == 1 for e in ends) and by == [(_own(one),), None]

        _look_until(graph, reader, both_counted)  # one twin answered for, the other's topic counted by topic


def test_a_steady_graph_asks_only_for_its_node_list_until_a_read_is_due(reader: RosPeer) -> None:
    """While nothing changes a look asks rmw one question (the node list); the topic list is read again when
    its period is up (longer the more its reading cost, at most `RECOUNT_S`) and every topic is counted
    every `RECOUNT_S`; a node that comes is listed and counted at the next look, and once more when
    discovery has settled."""
    run = next(_ids)
    graph = GraphView(_own(reader))
    node = reader.node
    quiet = wait_quiet(
        lambda: (sorted(node.get_node_names_and_namespaces()), node.get_topic_names_and_types()), 1.0, TIMEOUT
    )
    assert quiet, "the graph never held still (the other tests' nodes leaving)"
    t0 = time.monotonic()
    assert graph.look(node, t0, period=0.1) == (True, True), "a first look reads everything"
    graph.took(0.004)  # a read that cost 4 ms: read again 0.8 s later
    assert graph.list_period == pytest.approx(0.004 / LIST_SHARE)
    before = graph.queries
    assert graph.look(node, t0 + 0.5, period=0.1) == (False, False)
    assert graph.queries == before + 1, "the node list alone"
    assert graph.look(node, t0 + 0.9, period=0.1) == (True, False), "the topic list, its period up"
    counted_before = graph.recounts
    assert graph.look(node, t0 + RECOUNT_S + 0.1, period=0.1)[1], "every topic counted, its period up"
    assert graph.recounts == counted_before + 1
    graph.took(1.0)
    assert graph.list_period == RECOUNT_S, "never less often than the recount"
    topic = f"/graph_test/arrival_{run}"
    with RosPeer(f"graph_arrival_{run}") as arrival:
        arrival.publisher(topic, Float64)
        now = [t0 + RECOUNT_S + 0.2]

        def counted() -> bool:
            now[0] += 0.01  # (far less than any period: only the change makes the reads due)
            graph.look(node, now[0], period=0.1)
            return topic in graph.counts and graph.counts[topic].publishers == 1

        assert wait_until(counted, TIMEOUT), "the new node's topic, at a look after it came"
        changed = now[0]
        assert graph.look(node, changed + SETTLE_S + 0.01, period=0.1)[1], "counted again once settled"

"""The discovery census: participants of this host a node found, its discovery sockets' drops, the reach."""

from __future__ import annotations

import os
import socket
from collections.abc import Iterator
from pathlib import Path

import pytest

from dbglog._ros._census import (
    Census,
    discovery_reach,
    metatraffic_ports,
    participant_sockets,
    take_census,
    udp_sockets,
    unseen_holders,
)
from dbglog._ros._node import PrivateNode
from tests._ros import RosPeer, wait_until

TIMEOUT = 60

_HEADER = "  sl  local_address rem_address   st tx_queue rx_queue tr tm->when retrnsmt   uid  timeout inode"


def _line(sl: int, address: str, inode: int, drops: int) -> str:
    """One /proc/net/udp line: the local address, its inode and drops (the rest as the kernel writes it)."""
    rest = "00000000:00000000 00:00000000 00000000     0        0"
    return f" {sl}: {address} {'0' * (len(address) - 5)}:0000 07 {rest} {inode} 2 000000005ded3ffa {drops}"


_TABLE = "\n".join(
    [
        _HEADER + " ref pointer drops",
        _line(1432, "00000000:77C4", 876401, 0),
        _line(2310, "020200C0:77C6", 794104, 17),
        " 9999: garbage",
    ]
)
_TABLE6 = "\n".join([_HEADER + " ref pointer drops", _line(451, "0" * 32 + ":77C8", 12345, 3)])


@pytest.fixture(scope="module")
def ros() -> Iterator[PrivateNode]:
    """One private node for the module (a participant of the test's domain)."""
    node = PrivateNode("census_test")
    yield node
    node.close()


def _domain() -> int:
    return int(os.environ["ROS_DOMAIN_ID"])


def test_udp_tables_parse_into_port_inode_and_drops() -> None:
    """Both /proc/net/udp and udp6 lines give (port, inode, drops); headers and odd lines are skipped."""
    sockets = udp_sockets([_TABLE, _TABLE6])
    assert [(s.port, s.inode, s.drops) for s in sockets] == [
        (0x77C4, 876401, 0),
        (0x77C6, 794104, 17),
        (0x77C8, 12345, 3),
    ]


def test_metatraffic_ports_follow_the_rtps_port_mapping() -> None:
    """Domain d's participant i listens on 7410 + 250 d + 2 i: 120 ids, below the next domain's ports."""
    ports = metatraffic_ports(93)
    assert (ports[0], ports[1], ports[-1]) == (30660, 30662, 30660 + 2 * 119)
    assert ports[-1] < metatraffic_ports(94)[0] - 10
    assert 30661 not in ports  # a participant's user-data port


def test_a_participant_is_a_discovery_port_with_its_user_data_port_bound_too() -> None:
    """A metatraffic port counts only beside the user-data port above it: a lone socket there (a sending
    socket's ephemeral port, for domains above 101) is not a participant."""
    first = metatraffic_ports(120)[0]
    table = "\n".join(
        [
            _HEADER + " ref pointer drops",
            _line(1, f"0100007F:{first:04X}", 11, 0),
            _line(2, f"0100007F:{first + 1:04X}", 12, 0),
            _line(3, f"00000000:{first + 2:04X}", 13, 0),  # alone: an ephemeral socket
            _line(4, f"00000000:{first + 5:04X}", 14, 0),  # a user-data port alone
        ]
    )
    assert [s.inode for s in participant_sockets(udp_sockets([table]), 120)] == [11]


@pytest.mark.parametrize(
    ("environ", "reach"),
    [
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}, "host"),
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "localhost"}, "host"),
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF"}, "host"),
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}, "network"),
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT"}, "network"),
        ({}, "network"),
        ({"ROS_LOCALHOST_ONLY": "1"}, "host"),
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_STATIC_PEERS": "192.168.1.7"}, "network"),
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_STATIC_PEERS": " ; "}, "host"),
    ],
)
def test_discovery_reach_reads_the_range_as_rcl_does(environ: dict[str, str], reach: str) -> None:
    """LOCALHOST and OFF keep discovery on this host; SUBNET, the system default and static peers do not."""
    assert discovery_reach(environ) == reach


def test_every_participant_of_this_host_is_found(ros: PrivateNode) -> None:
    """A second participant on the host is counted on the host and, once discovered, as found."""
    with RosPeer("census_peer"):
        census: list[Census] = []

        def found_all() -> bool:
            census.append(take_census(ros.node))
            return census[-1].unseen == 0 and (census[-1].local or 0) >= 2

        assert wait_until(found_all, TIMEOUT), (census[-1:], unseen_holders(census[-1]))
    final = census[-1]
    assert final.local == final.found
    assert final.dropped is not None


def test_a_participant_never_found_is_unseen_and_a_full_socket_counts_its_drops(ros: PrivateNode) -> None:
    """A socket on a participant's discovery port that never answers is a participant never found; when
    it is this process's and overflows, its dropped datagrams are counted."""
    assert wait_until(lambda: take_census(ros.node).unseen == 0, TIMEOUT)
    before = take_census(ros.node)
    port = metatraffic_ports(_domain())[-1]
    silent = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    user_data = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    silent.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    try:
        silent.bind(("127.0.0.1", port))
        assert take_census(ros.node).local == before.local  # one port alone is not a participant
        user_data.bind(("127.0.0.1", port + 1))
        census = take_census(ros.node)
        assert census.unseen == 1
        assert census.local == (before.local or 0) + 1
        assert unseen_holders(census) == [f"pid {os.getpid()} ({_cmdline(os.getpid())})"]
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
            for _ in range(200):  # never read: the kernel drops what the small buffer cannot hold
                sender.sendto(b"x" * 1000, ("127.0.0.1", port))
        after = take_census(ros.node)
        assert (after.dropped or 0) - (before.dropped or 0) > 0, (before, after)
    finally:
        silent.close()
        user_data.close()
    assert take_census(ros.node).unseen == 0


def test_the_engine_takes_a_census_at_each_graph_poll_when_asked() -> None:
    """Engine(census=True) answers census() once it polled the graph; without it, census() is None."""
    from dbglog.viewer._data._engine import Engine

    with Engine(node_name="census_engine", census=True, graph_period=0.05) as engine:
        assert wait_until(lambda: engine.census() is not None, TIMEOUT)
        census = engine.census()
        assert census is not None
        assert (census.local or 0) >= 1
        assert census.found >= 1
    with Engine(node_name="census_engine_off", graph_period=0.05) as engine:
        assert wait_until(lambda: engine.stats().graph_polls >= 2, TIMEOUT)
        assert engine.census() is None


def _cmdline(pid: int) -> str:
    words = Path(f"/proc/{pid}/cmdline").read_bytes().rstrip(b"\0").replace(b"\0", b" ").decode()
    return words if len(words) <= 60 else f"{words[:24]}…{words[-35:]}"


def _process(proc: Path, pid: int, command: bytes, inodes: list[int]) -> None:
    """A fake /proc/<pid>: its command line and an fd per socket inode (and one that is not a socket)."""
    (proc / str(pid) / "fd").mkdir(parents=True)
    (proc / str(pid) / "cmdline").write_bytes(command)
    for fd, inode in enumerate(inodes, start=3):
        (proc / str(pid) / "fd" / str(fd)).symlink_to(f"socket:[{inode}]")
    (proc / str(pid) / "fd" / "0").symlink_to("/dev/null")


def test_the_participants_not_found_are_named_by_their_process_or_else_their_port(tmp_path: Path) -> None:
    """A process holding more discovery ports than participants of its pid found is named once per
    participant not found, with its command line cut to 60 characters in its middle; a forked child
    sharing the socket is not named twice; what is left is named by the ports whose holders cannot be
    read."""
    talker = b"python3\0talker.py\0--rate\0" + b"9" * 80 + b"\0"
    _process(tmp_path, 70000, talker, [101, 102])
    _process(tmp_path, 70001, b"fork\0", [101])  # a child holding its parent's socket
    _process(tmp_path, 4242, b"found_node\0", [103])
    (tmp_path / "self").mkdir()
    census = Census(
        local=4,
        found=2,
        ports=((7660, 101), (7662, 102), (7664, 103), (7666, 104)),
        found_pids=((70000 & 0xFFFF).to_bytes(2, "little"), (4242).to_bytes(2, "little")),
    )
    named = unseen_holders(census, proc=str(tmp_path))
    assert named == ["pid 70000 (python3 talker.py --rate…" + "9" * 35 + ")", "port 7666"]
    everyone = Census(local=4, found=4, ports=census.ports)
    assert unseen_holders(everyone, proc=str(tmp_path)) == []
    three_unread = Census(local=4, found=3, ports=((7660, 201), (7662, 202), (7664, 203), (7666, 204)))
    assert unseen_holders(three_unread, proc=str(tmp_path)) == [
        "1 of ports 7660, 7662, 7664, 7666 (their processes cannot be read)"
    ]

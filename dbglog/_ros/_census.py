"""What a node has found of the DDS participants on this host, and whether discovery traffic to it was lost.

Every Fast DDS participant of a domain listens on an RTPS metatraffic unicast port
(``7410 + 250 * domain + 2 * i``) and on the user-data unicast port above it, so the pairs of ports bound
on this host (``/proc/net/udp``) count the participants here (one port alone is not a participant:
domains above 101 have their ports in Linux's ephemeral range, where any process's sending socket may
land); the GUID prefixes of the ``ros_discovery_info`` writers a node knows (one per ROS participant:
vendor ``01 0f``, then the host's 2 bytes, then the process id's low 2 bytes) tell which of them it found.
The kernel counts the datagrams each socket dropped because its buffer was full: discovery data lost that
way is sent again within a heartbeat period (1 s), so a graph is settled only that long after its node's
last drop. Participants on other hosts cannot be counted: `discovery_reach` says whether there can be
any. Linux and Fast DDS only; elsewhere the counts are None.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any, Literal

__all__ = [
    "Census",
    "discovery_reach",
    "metatraffic_ports",
    "participant_prefixes",
    "participant_sockets",
    "take_census",
    "udp_sockets",
    "unseen_holders",
]

_PORT_BASE = 7400
_DOMAIN_GAIN = 250
_METATRAFFIC_UNICAST = 10
_PARTICIPANT_GAIN = 2
_PARTICIPANT_IDS = 120
"""Participant ids below this keep a domain's ports below the next domain's."""
_UDP_TABLES = ("/proc/net/udp", "/proc/net/udp6")
_FAST_DDS = b"\x01\x0f"
"""eProsima's RTPS vendor id: the first two bytes of a Fast DDS GUID prefix."""
_DISCOVERY_TOPIC = "ros_discovery_info"


@dataclass(frozen=True, slots=True)
class UdpSocket:
    """One bound UDP socket of a ``/proc/net/udp`` table."""

    port: int
    inode: int
    drops: int


def udp_sockets(tables: Iterable[str]) -> list[UdpSocket]:
    """Parse ``/proc/net/udp``-format tables (``/proc/net/udp6`` too) into their sockets.

    Args:
        tables: the tables' text; lines that are not a socket are skipped.
    """
    sockets = []
    for table in tables:
        for line in table.splitlines():
            fields = line.split()
            if len(fields) < 13 or not fields[0].endswith(":") or ":" not in fields[1]:
                continue
            try:
                port = int(fields[1].rsplit(":", 1)[1], 16)
                sockets.append(UdpSocket(port, int(fields[9]), int(fields[12])))
            except ValueError:
                continue
    return sockets


def metatraffic_ports(domain_id: int) -> range:
    """Return the RTPS metatraffic unicast ports participants of `domain_id` listen on."""
    first = _PORT_BASE + _DOMAIN_GAIN * domain_id + _METATRAFFIC_UNICAST
    return range(first, first + _PARTICIPANT_GAIN * _PARTICIPANT_IDS, _PARTICIPANT_GAIN)


def participant_sockets(sockets: Iterable[UdpSocket], domain_id: int) -> list[UdpSocket]:
    """Return the metatraffic sockets of `domain_id`'s participants among `sockets`: those whose port's
    user-data port (the one above it) is bound too.

    Args:
        sockets: the host's UDP sockets (`udp_sockets`).
        domain_id: the DDS domain.
    """
    sockets = list(sockets)
    bound = {s.port for s in sockets}
    wanted = metatraffic_ports(domain_id)
    return [s for s in sockets if s.port in wanted and s.port + 1 in bound]


def _read_tables() -> list[str] | None:
    tables = []
    for path in _UDP_TABLES:
        try:
            with open(path, encoding="ascii", errors="replace") as f:
                tables.append(f.read())
        except OSError:
            continue
    return tables or None


def _socket_inodes(fd_dir: str) -> set[int]:
    """Return the inodes of the sockets open in a process's fd directory (none when it cannot be read)."""
    inodes: set[int] = set()
    try:
        fds = os.listdir(fd_dir)
    except OSError:  # another user's process, or gone
        return inodes
    for fd in fds:
        try:
            target = os.readlink(f"{fd_dir}/{fd}")
        except OSError:  # closed meanwhile
            continue
        if target.startswith("socket:["):
            inodes.add(int(target[8:-1]))
    return inodes


def participant_prefixes(node: Any) -> frozenset[bytes]:
    """Return the 12-byte GUID prefixes of the ROS participants `node` has found (its own included)."""
    infos = node.get_publishers_info_by_topic(_DISCOVERY_TOPIC, no_mangle=True)
    return frozenset(bytes(info.endpoint_gid)[:12] for info in infos)


def discovery_reach(environ: Mapping[str, str] | None = None) -> Literal["host", "network"]:
    """Return how far DDS discovery reaches, as rcl reads ``ROS_AUTOMATIC_DISCOVERY_RANGE`` (and the
    deprecated ``ROS_LOCALHOST_ONLY``) and ``ROS_STATIC_PEERS``: ``"host"`` when every participant it can
    find is on this host.

    Args:
        environ: the environment (the process's by default).
    """
    env = os.environ if environ is None else environ
    if env.get("ROS_STATIC_PEERS", "").strip(" ;"):
        return "network"
    reach = env.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip().upper()
    if not reach:
        return "host" if env.get("ROS_LOCALHOST_ONLY", "").strip() == "1" else "network"
    return "host" if reach in ("LOCALHOST", "OFF") else "network"


@dataclass(frozen=True, slots=True)
class Census:
    """What a node has found of the participants on its host."""

    local: int | None
    """Participants of the domain on this host, the node's own included (None: cannot be told)."""
    found: int
    """Of those, the ones the node found (participants of other DDS vendors are counted here too)."""
    dropped: int | None = None
    """Datagrams this process's discovery sockets dropped so far (None: cannot be told)."""
    ports: tuple[tuple[int, int], ...] = ()
    """The (port, socket inode) of each discovery socket of the domain on this host."""
    found_pids: tuple[bytes, ...] = ()
    """The process-id bytes of each Fast DDS participant of this host the node found (repeats kept)."""

    @property
    def unseen(self) -> int | None:
        """Participants of this host not found yet (None: unknown)."""
        return None if self.local is None else max(0, self.local - self.found)


def take_census(node: Any, *, pid: int | None = None) -> Census:
    """Count the participants on `node`'s host and those it found, and its discovery sockets' drops.

    Args:
        node: an rclpy node on Fast DDS (another middleware's GUIDs are not read: the counts are None).
        pid: the process id in the node's GUID prefix (this process's).
    """
    import rclpy.utilities

    tables = _read_tables()
    if tables is None or not rclpy.utilities.get_rmw_implementation_identifier().startswith("rmw_fastrtps"):
        return Census(None, 0)
    sockets = participant_sockets(udp_sockets(tables), int(node.context.get_domain_id()))
    mine = _socket_inodes("/proc/self/fd")
    dropped = sum(s.drops for s in sockets if s.inode in mine)
    local = len({s.port for s in sockets})
    ports = tuple(sorted({(s.port, s.inode) for s in sockets}))
    prefixes = participant_prefixes(node)
    pid16 = ((os.getpid() if pid is None else pid) & 0xFFFF).to_bytes(2, "little")
    hosts = {p[2:4] for p in prefixes if p[:2] == _FAST_DDS and p[4:6] == pid16}
    if len(hosts) > 1:  # a process on another host has this one's pid bits: this host cannot be told
        return Census(None, 0, dropped)
    if not hosts:  # the node has not found its own participant yet
        return Census(local, 0, dropped, ports)
    (host,) = hosts
    here = [p for p in prefixes if p[:2] != _FAST_DDS or p[2:4] == host]
    return Census(local, len(here), dropped, ports, tuple(p[4:6] for p in here if p[:2] == _FAST_DDS))


def unseen_holders(census: Census, *, proc: str = "/proc") -> list[str]:
    """Name the processes of this host whose participants `census` counts but its node has not found.

    A socket's holder is found by its inode among the open files of the processes this user may read
    (``/proc/<pid>/fd``); a process holding more discovery ports than the node found participants of its
    process id is named, with its command line, once per participant not found. The rest not found are
    among the ports whose holders cannot be read (another user's processes): those are named by number.

    Args:
        census: a census taken with `take_census`.
        proc: the proc file system's mount point.
    """
    if not census.unseen:
        return []
    wanted = {inode: port for port, inode in census.ports}
    holders: dict[int, list[int]] = {}
    for pid, inode in _socket_holders(proc, set(wanted)):
        if inode in wanted:  # a forked child shares its parent's sockets: the lowest pid is named
            holders.setdefault(pid, []).append(wanted.pop(inode))
    named = []
    for pid, ports in sorted(holders.items()):
        missing = len(set(ports)) - census.found_pids.count((pid & 0xFFFF).to_bytes(2, "little"))
        named += [f"pid {pid} ({_command(proc, pid)})"] * max(0, missing)
    unread = sorted(set(wanted.values()))
    left = census.unseen - len(named)
    if left > 0 and unread:
        named += (
            [f"port {port}" for port in unread]
            if left >= len(unread)
            else [f"{left} of ports {', '.join(map(str, unread))} (their processes cannot be read)"]
        )
    return named


def _socket_holders(proc: str, inodes: set[int]) -> Iterator[tuple[int, int]]:
    """Yield (pid, inode) for each of `inodes` open in a process this user may read, by rising pid."""
    if not inodes:
        return
    try:
        pids = sorted(int(name) for name in os.listdir(proc) if name.isdigit())
    except OSError:
        return
    for pid in pids:
        for inode in _socket_inodes(f"{proc}/{pid}/fd") & inodes:
            yield pid, inode


def _command(proc: str, pid: int) -> str:
    """Return `pid`'s command line, cut to 60 characters in its middle ("?" when it cannot be read)."""
    try:
        with open(f"{proc}/{pid}/cmdline", "rb") as f:
            words = f.read().rstrip(b"\0").replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return "?"
    return words if len(words) <= 60 else f"{words[:24]}…{words[-35:]}"  # the program, and its script

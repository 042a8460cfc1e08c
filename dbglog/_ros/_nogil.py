"""Publish serialized bytes without holding the GIL during the DDS write.

rclpy's ``Publisher.publish(bytes)`` calls ``rcl_publish_serialized_message`` with the GIL held (rclpy
7.1's ``publish_raw`` releases nothing), so every Python thread of the process waits while Fast DDS
writes a reliable message to a matched reader: tens of µs, hundreds at its tail. dbglog's publisher
thread sends one batch every 10 ms; a user's control loop that wakes up meanwhile would wait for it.
Here the same rcl function is called through ``ctypes``, which releases the GIL for the length of the
foreign call. The publisher's handle is held (``with handle``: rclpy's guard against destroying an entity
in use) around the call, exactly as ``Publisher.publish`` does. No import of rclpy at module level.
"""

from __future__ import annotations

import ctypes
import functools
import logging
from collections.abc import Callable
from typing import Any

__all__ = ["publisher_address", "rcl_addresses", "unlocked_publish"]

_log = logging.getLogger("dbglog.ros")


class _Allocator(ctypes.Structure):
    """``rcutils_allocator_t``: four function pointers and a state (all NULL: never used to publish)."""

    _fields_ = [
        ("allocate", ctypes.c_void_p),
        ("deallocate", ctypes.c_void_p),
        ("reallocate", ctypes.c_void_p),
        ("zero_allocate", ctypes.c_void_p),
        ("state", ctypes.c_void_p),
    ]


class _SerializedMessage(ctypes.Structure):
    """``rcl_serialized_message_t`` (``rcutils_uint8_array_t``): the bytes, their length and capacity."""

    _fields_ = [
        ("buffer", ctypes.c_char_p),
        ("buffer_length", ctypes.c_size_t),
        ("buffer_capacity", ctypes.c_size_t),
        ("allocator", _Allocator),
    ]


@functools.cache
def _rcl() -> tuple[Any, Any]:
    """Return rcl's publish of serialized bytes and rcutils' error reset, from the libraries rclpy loaded."""
    # By soname: the libraries already loaded by rclpy's extension are the ones returned.
    write = ctypes.CDLL("librcl.so").rcl_publish_serialized_message
    write.argtypes = [ctypes.c_void_p, ctypes.POINTER(_SerializedMessage), ctypes.c_void_p]
    write.restype = ctypes.c_int32
    reset = ctypes.CDLL("librcutils.so").rcutils_reset_error  # what rcl_reset_error() expands to
    reset.argtypes = []
    reset.restype = None
    return write, reset


def rcl_addresses() -> tuple[int, int] | None:
    """Return the addresses of ``rcl_publish_serialized_message`` and ``rcutils_reset_error``, or None.

    For dbglog's compiled writer thread (``dbglog/api/_writer.c``), which calls them without Python.
    """
    try:
        write, reset = _rcl()
        addresses = (ctypes.cast(write, ctypes.c_void_p).value, ctypes.cast(reset, ctypes.c_void_p).value)
    except Exception as exc:  # another rclpy, no librcl by that name
        _log.debug("dbglog: no rcl functions for the writer thread (%s: %s)", type(exc).__name__, exc)
        return None
    if addresses[0] is None or addresses[1] is None:
        return None
    return addresses[0], addresses[1]


def publisher_address(publisher: Any) -> int | None:
    """Return the address of `publisher`'s ``rcl_publisher_t`` (an ``rclpy`` Publisher), or None."""
    try:
        handle = publisher.handle
        with handle:
            pointer = handle.pointer
    except Exception:
        return None
    return int(pointer) if pointer else None


def unlocked_publish(publisher: Any, *, guarded: bool = True) -> Callable[[bytes], None] | None:
    """Return a function that publishes serialized bytes on `publisher` with the GIL released.

    `publisher` is an ``rclpy.publisher.Publisher``. None when this rclpy or its ``librcl`` cannot be
    reached this way (the caller keeps ``publisher.publish``). A failed write falls back to
    ``publisher.publish`` once, which raises rclpy's own error. Not `guarded`, the publisher's handle
    is not held around each write: only for a publisher that nobody destroys while it may be in use.
    """
    try:
        write, reset = _rcl()
    except Exception as exc:  # another rclpy, no librcl by that name: rclpy's publish it is
        _log.debug("dbglog: publishing with the GIL held (%s: %s)", type(exc).__name__, exc)
        return None
    pointer = publisher_address(publisher)
    if pointer is None:
        return None
    handle, fallback = publisher.handle, publisher.publish

    def publish(data: bytes) -> None:
        """Publish `data` (one serialized message) on the publisher."""
        message = _SerializedMessage(data, len(data), len(data))  # its own: callers may be concurrent
        if guarded:
            with handle:  # rclpy destroys no entity while its handle is held
                ret = write(handle.pointer, ctypes.byref(message), None)  # ctypes drops the GIL for this
        else:
            ret = write(pointer, ctypes.byref(message), None)
        if ret != 0:
            reset()
            fallback(data)

    return publish

"""Finding a watch's place: loaded files, the code objects of a line, its source and names."""

from __future__ import annotations

import os
import threading
import types

import pytest

from dbglog.watch._code import (
    CodeLookupError,
    find_file,
    loaded_files,
    locate,
    names_at,
    read_source,
    user_file,
)
from tests._watch_targets import TARGETS, line_of, load_targets


@pytest.fixture(scope="module")
def targets() -> types.ModuleType:
    """The targets module, loaded once."""
    return load_targets()


def _codes(marker: str) -> list[str]:
    files = loaded_files()
    located = locate(str(TARGETS), line_of(marker), files[str(TARGETS)])
    return sorted(getattr(c, "co_qualname", c.co_name) for c in located.codes)


def test_loaded_files_list_the_targets_module(targets: types.ModuleType) -> None:
    """A loaded module's source file is listed, with the module; it counts as the user's, pytest does not."""
    files = loaded_files()
    assert files[str(TARGETS)] == [targets]
    assert user_file(str(TARGETS))
    assert not user_file(pytest.__file__)
    assert not user_file(os.__file__)


def test_find_file_by_path_or_unique_suffix(targets: types.ModuleType) -> None:
    """A file is named by its path or a unique suffix; the user's file wins over a library's of that name."""
    files = [str(TARGETS), "/opt/ros/jazzy/lib/python3.12/site-packages/x/targets.py", "/a/b/node.py"]
    assert find_file(str(TARGETS), files) == str(TARGETS)
    assert find_file("watch/targets.py", files) == str(TARGETS)
    assert find_file("targets.py", files) == str(TARGETS)
    assert find_file("./b/node.py", files) == "/a/b/node.py"
    assert find_file("elsewhere/node.py", files, local_path="/a/b/node.py") == "/a/b/node.py"
    with pytest.raises(CodeLookupError, match=r"loaded no file nope\.py") as info:
        find_file("nope.py", files)
    assert info.value.state == "no_file"
    with pytest.raises(CodeLookupError, match="several loaded files"):
        find_file("node.py", ["/a/node.py", "/b/node.py"])


@pytest.mark.parametrize(
    ("marker", "qualname"),
    [
        ("plain", "plain"),
        ("method", "Robot.step"),
        ("property", "Robot.fast"),
        ("static", "Robot.helper"),
        ("inner", "outer.<locals>.inner"),
        ("decorated", "decorated"),
        ("loopfn", "make_callbacks.<locals>.callback"),
        ("comp", "squares"),
        ("thread", "spin"),
    ],
)
def test_locate_finds_the_code_of_a_line(targets: types.ModuleType, marker: str, qualname: str) -> None:
    """Functions, methods, properties, nested and decorated functions, a comprehension's line: all found."""
    assert _codes(marker) == [qualname]


def test_a_function_defined_in_a_loop_is_one_code_object(targets: types.ModuleType) -> None:
    """Each function a loop defines shares the code object that a watch is put on."""
    first, second = targets.make_callbacks(2)
    assert first.__code__ is second.__code__
    files = loaded_files()
    located = locate(str(TARGETS), line_of("loopfn"), files[str(TARGETS)])
    assert located.codes == (first.__code__,)


def test_running_frames_are_found(targets: types.ModuleType) -> None:
    """Code running on a thread's stack is found through its frame, even when no name holds its function."""
    stop = threading.Event()
    out: list[int] = []
    fn = types.FunctionType(targets.spin.__code__, {"time": __import__("time")}, "anonymous")
    thread = threading.Thread(target=fn, args=(stop, out), daemon=True)
    thread.start()
    try:
        files = loaded_files()
        located = locate(str(TARGETS), line_of("thread"), files[str(TARGETS)])
        assert located.codes == (targets.spin.__code__,)
    finally:
        stop.set()
        thread.join()


def test_no_line_says_why(targets: types.ModuleType) -> None:
    """A comment line, or a line past the end, is `no_line`, with the reason."""
    files = loaded_files()[str(TARGETS)]
    with pytest.raises(CodeLookupError, match="holds no code") as info:
        locate(str(TARGETS), line_of("comment"), files)
    assert info.value.state == "no_line"
    with pytest.raises(CodeLookupError, match="there is no line 99999"):
        locate(str(TARGETS), 99999, files)


def test_source_and_names(targets: types.ModuleType) -> None:
    """The file's lines read as Python reads source; a line's names: its function's and its module's."""
    lines = read_source(str(TARGETS))
    assert lines[line_of("plain") - 1].strip() == "total += i  # L:plain"
    files = loaded_files()[str(TARGETS)]
    local, global_ = names_at(locate(str(TARGETS), line_of("plain"), files), files)
    assert local == ["i", "n", "total"]
    assert {"Robot", "plain", "CONSTANT"} <= set(global_)
    assert not any(name.startswith("__") for name in global_)
    local, _ = names_at(locate(str(TARGETS), line_of("inner"), files), files)
    assert local == ["k", "v"]

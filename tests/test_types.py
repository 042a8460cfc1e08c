"""The one type gate (type name -> message class) and the one primitive table, in dbglog._ros._types."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from geometry_msgs.msg import Twist
from std_msgs.msg import Float64

from dbglog._ros._types import PRIMITIVES, TypeGateError, message_class, normalize_type, primitive
from dbglog.api._convert import ConversionError, resolve_type
from dbglog.viewer._data._fields import FieldPathError
from dbglog.viewer._data._fields import message_class as field_message_class
from dbglog.viewer._data._interfaces import InterfaceError, message_type, value_kind


def test_gate_resolves_installed_types_in_both_spellings() -> None:
    """pkg/msg/Type and pkg/Type give the installed class; the SDK, fields and interfaces agree."""
    assert message_class("std_msgs/msg/Float64") is Float64
    assert message_class("geometry_msgs/Twist") is Twist
    assert resolve_type("std_msgs/msg/Float64") is Float64
    assert field_message_class("geometry_msgs/msg/Twist") is Twist
    assert message_type("geometry_msgs/Twist") is Twist
    assert normalize_type(" std_msgs/Bool ") == "std_msgs/msg/Bool"


@pytest.mark.parametrize(
    ("name", "reason"),
    [
        ("Float64", "malformed"),
        ("std_msgs/srv/Float64", "malformed"),
        ("std_msgs/msg/float64", "malformed"),
        ("os.path/msg/Thing", "malformed"),
        ("../x/msg/Y", "malformed"),
        ("std_msgs/msg/NoSuchType", "not_installed"),
        ("os/msg/Path", "not_installed"),
        ("no_such_pkg/msg/Thing", "not_installed"),
    ],
)
def test_gate_refuses_with_a_reason(name: str, reason: str) -> None:
    """A malformed or uninstalled name is refused with its reason; each feature says it in its own words."""
    with pytest.raises(TypeGateError) as caught:
        message_class(name)
    assert caught.value.reason == reason
    with pytest.raises(ConversionError, match="pkg/msg/Type" if reason == "malformed" else "not installed"):
        resolve_type(name)
    with pytest.raises(FieldPathError, match="pkg/msg/Name" if reason == "malformed" else "not installed"):
        field_message_class(name)
    with pytest.raises(InterfaceError, match=name.strip() if reason == "malformed" else "not installed"):
        message_type(name)


def test_no_type_string_imports_an_arbitrary_module(tmp_path: Path) -> None:
    """A module that is not an installed interface package is never imported, whichever door asks."""
    evil = tmp_path / "evilpkg"
    evil.mkdir()
    marker = tmp_path / "imported"
    (evil / "__init__.py").write_text(f"open({str(marker)!r}, 'w').close()\n")
    (evil / "msg.py").write_text("class Thing:\n    pass\n")
    code = (
        "import sys\n"
        f"sys.path.insert(0, {str(tmp_path)!r})\n"
        "from dbglog._ros._types import TypeGateError, message_class\n"
        "from dbglog.api._convert import ConversionError, resolve_type\n"
        "from dbglog.viewer._data._fields import FieldPathError, message_class as field_class\n"
        "from dbglog.viewer._data._interfaces import InterfaceError, message_type\n"
        "for call, error in [(message_class, TypeGateError), (resolve_type, ConversionError),\n"
        "                    (field_class, FieldPathError), (message_type, InterfaceError)]:\n"
        "    for name in ('evilpkg/msg/Thing', 'evilpkg/Thing', 'antigravity/msg/Fly', 'this/msg/S'):\n"
        "        try:\n"
        "            call(name)\n"
        "        except error as exc:\n"
        "            assert 'not installed' in str(exc), exc\n"
        "        else:\n"
        "            raise AssertionError(name)\n"
        "print(sorted(m for m in ('evilpkg', 'antigravity', 'this') if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    assert out.stdout.strip() == "[]"
    assert not marker.exists()


def test_one_primitive_table_for_fields_and_forms() -> None:
    """Field display and control forms read the same table: every float/int/bool/string name agrees."""
    for name in ("float", "double", "float32", "float64", "long double"):
        found = primitive(name)
        assert found is not None
        assert found.kind == "float"
        assert value_kind(name) == "float"
    for name in ("int8", "uint64", "octet", "char", "byte", "long long"):
        assert value_kind(name) == "int"
    assert value_kind("boolean") == "bool"
    assert value_kind("string<8>") == value_kind("wstring") == "string"
    assert value_kind("sequence<double>") is None
    assert PRIMITIVES["float"].high == pytest.approx(3.4028234663852886e38)
    assert PRIMITIVES["uint16"].low == 0
    assert PRIMITIVES["int16"].low == -(2**15)
    assert all(p.size is None or p.dtype for p in PRIMITIVES.values())

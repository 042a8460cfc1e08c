"""The headless dashboard document: bindings' reference counts, edits, naming, file state; no display."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import dataclass, replace
from pathlib import Path

from dbglog.viewer._data._model import EVERY_ROBOT, SELECTED_ROBOT, Binding, FieldInfo, TopicInfo
from dbglog.viewer._data._robots import Fleet
from dbglog.viewer._data._static_source import StaticSource
from dbglog.viewer._document._canvas_doc import CanvasDoc, TopicSetup
from dbglog.viewer._document._dashboard import Dashboard, RawWidget, WidgetConfig
from dbglog.viewer._widgets._geometry import Part, Rect

SPEED = Binding("/rosdashboard/motor/speed")
TEMP = Binding("/rosdashboard/motor/temp")


@dataclass(eq=False)
class Item:
    """A placed widget without a window: what the document needs and nothing more."""

    config: WidgetConfig | RawWidget
    label: str | None = "Dial"
    publishes: bool = False
    resolved: tuple[Binding, ...] = ()

    @property
    def name(self) -> str:
        """The title."""
        return self.config.name

    @property
    def series(self) -> tuple[Binding, ...]:
        """The bindings filled by the source (none for a control), as last resolved."""
        return () if self.publishes else self.resolved

    def resolve(self, fleet: Fleet) -> tuple[Binding, ...]:
        """Resolve robot-relative bindings: the series to fill."""
        self.resolved = fleet.expand_all(self.config.bindings)
        return self.series

    @property
    def rect(self) -> Rect:
        """Place and size."""
        return Rect(*self.config.geometry())

    def set_bindings(self, bindings: tuple[Binding, ...]) -> None:
        """Point at new series."""
        config = self.config.editable
        if config is not None:
            self.config = replace(config, bindings=bindings)

    def rename(self, name: str) -> None:
        """Change the title."""
        self.config = self.config.renamed(name)


def dial(name: str = "Dial", *bindings: Binding, x: float = 0, y: float = 0) -> Item:
    """A dial at (x, y), 200 x 100, showing `bindings`."""
    return Item(WidgetConfig("dial", name, x, y, 200, 100, bindings))


def make_doc() -> tuple[CanvasDoc[Item], StaticSource, list[str]]:
    """A document over a static source, and the list its change notices are written to."""
    source = StaticSource()
    changes: list[str] = []
    doc: CanvasDoc[Item] = CanvasDoc(source, lambda: changes.append(doc.title("viewer")))
    return doc, source, changes


def selection(doc: CanvasDoc[Item]) -> Item | None:
    """The selected widget, read afresh (not narrowed by an earlier assignment)."""
    return doc.selected


def test_a_shared_binding_is_bound_once_and_released_by_its_last_user() -> None:
    """Two widgets on one topic bind it once at the source; it is unbound only when both are gone."""
    doc, source, _ = make_doc()
    a, b = doc.add(dial("a", SPEED)), doc.add(dial("b", SPEED, TEMP))
    assert source.bound == {SPEED, TEMP}
    assert source.bind_calls == 2
    assert doc.refs[SPEED] == 2
    assert doc.remove(a)
    assert source.bound == {SPEED, TEMP}
    assert doc.remove(b)
    assert source.bound == set()
    assert not doc.refs
    assert not doc.remove(b)


def test_a_control_binds_no_series() -> None:
    """A control's bindings are where it publishes: the document binds nothing for it."""
    doc, source, _ = make_doc()
    control = Item(WidgetConfig("slider", "Slider", 0, 0, 200, 100, (SPEED,)), "Slider", publishes=True)
    doc.add(control)
    assert source.bound == set()
    assert source.bind_calls == 0


def test_remove_clears_the_selection_and_marks_modified_once() -> None:
    """Removing the selected widget deselects it; the first edit retitles the window, later ones do not."""
    doc, _, changes = make_doc()
    a, b = doc.add(dial("a")), doc.add(dial("b"))
    doc.selected = a
    doc.remove(a)
    doc.remove(b)
    assert selection(doc) is None
    assert doc.dirty
    assert changes == ["viewer \u2014 untitled *"]


def test_new_bindings_rename_a_widget_still_named_by_its_type() -> None:
    """A widget named by its type takes its topic's name, a user's name stays; new series bind first."""
    doc, source, _ = make_doc()
    auto = doc.add(dial("Dial 2", TEMP))
    mine = doc.add(dial("boiler", TEMP))
    doc.set_bindings(auto, (SPEED,))
    doc.set_bindings(mine, (SPEED,))
    assert auto.name == "speed"
    assert mine.name == "boiler"
    assert source.bound == {SPEED}
    assert source.bind_calls == 2
    doc.set_bindings(auto, (TEMP,))
    assert auto.name == "temp"  # the name its last topic gave it follows the topic
    doc.rename(auto, "mine now")
    doc.set_bindings(auto, (SPEED,))
    assert auto.name == "mine now"
    assert doc.dirty


def test_bindings_that_follow_from_the_document_are_no_edit() -> None:
    """Bindings set without `edit` (a watch's topics) bind the series and leave the document unmodified."""
    doc, source, changes = make_doc()
    watched = doc.add(dial("Dial", TEMP))
    doc.set_bindings(watched, (SPEED,), edit=False)
    assert watched.config.bindings == (SPEED,)
    assert source.bound == {SPEED}
    assert not doc.dirty
    assert changes == []
    doc.set_bindings(watched, (TEMP,))
    assert doc.dirty


def test_replace_keeps_the_place_in_the_drawing_order_and_the_topic_name() -> None:
    """A retyped widget takes the old one's place; its series stay bound; auto naming carries over."""
    doc, source, _ = make_doc()
    old = doc.add(dial("Dial", TEMP))
    top = doc.add(dial("top"))
    doc.set_bindings(old, (SPEED,))
    config = old.config.editable
    assert config is not None
    new = Item(replace(config, type="gauge"), "Gauge")
    doc.selected = old
    doc.replace(old, new)
    assert doc.items == [new, top]
    assert selection(doc) is None
    assert source.bound == {SPEED}
    assert source.bind_calls == 2
    doc.set_bindings(new, (TEMP,))
    assert new.name == "temp"


def test_to_front_and_hit_find_the_topmost_widget_and_its_part() -> None:
    """The last widget is on top; a hit tells the title strip, the corner grip and the body apart."""
    doc, _, _ = make_doc()
    under, over = doc.add(dial("under")), doc.add(dial("over", x=100, y=50))
    assert doc.hit(150, 60, title_h=28, corner=18) == (over, Part.TITLE)
    assert doc.hit(290, 140, title_h=28, corner=18) == (over, Part.CORNER)
    assert doc.hit(20, 60, title_h=28, corner=18) == (under, Part.BODY)
    assert doc.hit(500, 500, title_h=28, corner=18) is None
    assert doc.to_front(under)
    assert doc.items[-1] is under
    assert not doc.to_front(under)
    assert doc.hit(150, 60, title_h=28, corner=18) == (under, Part.BODY)


def test_file_state_title_summary_and_saved_form(tmp_path: Path) -> None:
    """Saving names the file and clears the mark; the summary and the saved form follow the document."""
    doc, _, changes = make_doc()
    doc.add(dial("a", SPEED))
    doc.set_grid_size(1000)
    assert doc.grid_size == 400
    assert doc.dirty
    doc.saved(tmp_path / "board.json")
    assert doc.title("viewer") == "viewer \u2014 board.json"
    assert changes[-1] == "viewer \u2014 board.json"
    assert doc.summary() == [str(tmp_path / "board.json"), "1 widget", "grid 400px on"]
    saved = doc.dashboard()
    assert [w.name for w in saved.widgets] == ["a"]
    assert saved.grid_size == 400
    assert saved.snap
    doc.opened(Dashboard([], 10, False), None, ["one problem"])
    assert (doc.grid_size, doc.snap, doc.path, doc.dirty, doc.load_messages) == (
        10,
        False,
        None,
        False,
        ["one problem"],
    )


def test_unique_name_numbers_taken_names() -> None:
    """A new widget's name is its label, then "label 2", "label 3" as those are taken."""
    doc, _, _ = make_doc()
    assert doc.unique_name("Dial") == "Dial"
    doc.add(dial("Dial"))
    doc.add(dial("Dial 2"))
    assert doc.unique_name("Dial") == "Dial 3"


def test_clear_and_release_all_unbind_everything() -> None:
    """Clearing hands back every widget with its series released; closing releases previews too."""
    doc, source, _ = make_doc()
    a = doc.add(dial("a", SPEED))
    doc.bind(TEMP)  # an open Topic setup's preview
    assert doc.clear() == [a]
    assert doc.items == []
    assert source.bound == {TEMP}
    doc.release_all()
    assert source.bound == set()
    assert not doc.refs


def test_topic_setup_reads_the_graph_previews_and_applies() -> None:
    """The Topic setup's one interface: topics and fields from the source, a preview binding, the result."""
    doc, source, _ = make_doc()
    source.add_topic(SPEED.topic, "std_msgs/msg/Float64", [FieldInfo("data", "double", True)])
    item = doc.add(dial("Dial"))
    setup = TopicSetup(doc, item)
    assert [t.name for t in setup.topics()] == [SPEED.topic]
    assert [f.path for f in setup.fields(SPEED.topic)] == ["data"]
    setup.preview(SPEED)
    assert source.bound == {SPEED}
    setup.apply((SPEED,))
    setup.end_preview(SPEED)
    assert source.bound == {SPEED}
    assert item.name == "speed"
    assert item.config.bindings == (SPEED,)
    assert setup.snapshot(SPEED).binding == SPEED


def test_placeholder_config_answers_like_a_widget_config() -> None:
    """A placeholder moves and renames in its own format's keys, binds nothing and is not editable."""
    legacy = RawWidget({"type": "x", "name": "n", "posX": 1, "posY": 2, "extra": [1]}, "no such plugin")
    moved = legacy.placed(10, 20, 300, 200).renamed("m")
    assert moved.data == {
        "type": "x",
        "name": "m",
        "posX": 10,
        "posY": 20,
        "width": 300,
        "height": 200,
        "extra": [1],
    }
    assert moved.reason == "no such plugin"
    assert moved.editable is None
    assert moved.bindings == ()
    assert moved.stale_after is None
    config = WidgetConfig("dial", "d", 1, 2, 3, 4)
    assert config.editable is config
    assert config.placed(5, 6, 7, 8).geometry() == (5, 6, 7, 8)


def test_the_document_loads_no_dear_pygui() -> None:
    """The document module is headless: importing it does not import Dear PyGui."""
    code = (
        "import sys; import dbglog.viewer._document._canvas_doc; "
        "sys.exit(1 if any(m.startswith('dearpygui') for m in sys.modules) else 0)"
    )
    assert subprocess.run([sys.executable, "-c", code], timeout=60).returncode == 0


def robots_doc(selected: str | None = None) -> tuple[CanvasDoc[Item], StaticSource]:
    """A document whose fleet has seen robot1 and robot2 publish speed (robot2 also rpm)."""
    doc, source, _ = make_doc()
    doc.fleet = Fleet(selected)
    names = ("/robot1/rosdashboard/speed", "/robot2/rosdashboard/speed", "/robot2/rosdashboard/rpm")
    doc.fleet.observe([TopicInfo(n, ("std_msgs/msg/Float64",), 1) for n in names])
    return doc, source


def test_a_widget_on_the_selected_robot_binds_that_robots_topic_and_follows_a_switch() -> None:
    """Switching robots rebinds the widget (the new robot's series first), and is no edit of the file."""
    doc, source = robots_doc()
    relative = Binding("/rosdashboard/speed", robot=SELECTED_ROBOT)
    item = doc.add(dial("speed", relative))
    assert source.bound == {Binding("/robot1/rosdashboard/speed")}
    assert item.series == (Binding("/robot1/rosdashboard/speed"),)
    assert doc.sync_robots() == 0, "nothing changed since"
    doc.fleet.select("/robot2")
    assert doc.sync_robots() == 1
    assert source.bound == {Binding("/robot2/rosdashboard/speed")}
    assert item.series == (Binding("/robot2/rosdashboard/speed"),)
    assert not doc.dirty
    assert doc.dashboard().widgets[0].bindings == (relative,), "the file keeps the relative binding"
    assert doc.remove(item)
    assert source.bound == set()


def test_an_overlay_binds_every_robot_and_grows_as_robots_appear() -> None:
    """An every-robot binding binds each robot's topic; a robot that shows up later is bound too."""
    doc, source = robots_doc()
    item = doc.add(dial("all", Binding("/rosdashboard/rpm", robot=EVERY_ROBOT)))
    assert source.bound == {Binding("/robot2/rosdashboard/rpm")}
    doc.fleet.observe(
        [TopicInfo(f"/robot{i}/rosdashboard/rpm", ("std_msgs/msg/Float64",), 1) for i in (1, 2)]
    )
    doc.sync_robots()
    assert item.series == (Binding("/robot2/rosdashboard/rpm"), Binding("/robot1/rosdashboard/rpm"))
    assert source.bound == set(item.series)


def test_topic_setup_shows_the_selected_robots_topic_and_makes_bindings_relative() -> None:
    """Topic setup edits the concrete topic of the selected robot and gives back a relative binding."""
    doc, _ = robots_doc("/robot2")
    relative = Binding("/rosdashboard/speed", robot=SELECTED_ROBOT)
    item = doc.add(dial("speed", relative))
    setup = TopicSetup(doc, item)
    assert setup.shown(relative) == Binding("/robot2/rosdashboard/speed")
    assert setup.relative(Binding("/robot1/rosdashboard/rpm"), EVERY_ROBOT) == Binding(
        "/rosdashboard/rpm", robot=EVERY_ROBOT
    )
    assert setup.robot() == "robot2"
    plain, _, _ = make_doc()
    assert TopicSetup(plain, plain.add(dial("d"))).robot() is None, "no robots: nothing to follow"

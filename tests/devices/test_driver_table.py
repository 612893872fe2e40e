"""The one table of drivers (hapticgraph.devices.table): read from the entry-point groups, the
built-ins registered like plugins, a broken plugin skipped with a warning."""
import importlib.metadata

import pytest

from hapticgraph.devices import table
from hapticgraph.devices.driver_kind import DriverKind
from hapticgraph.devices.simulated_kind import SimulatedKind

BUILT_IN = ["evdev", "hid", "midi", "osc", "replay", "serial", "simulated"]


@pytest.fixture
def fresh(monkeypatch):
    """The table read again, with the entry points `fresh(extra)` adds to the installed ones."""
    real = importlib.metadata.entry_points

    def clear():
        for cached in (table._installed, table._drivers, table._inputs):
            cached.cache_clear()

    def use(extra=(), installed=True):
        def entry_points():
            groups = (table.DRIVER_GROUP, table.INPUT_GROUP)
            found = [ep for g in groups for ep in real().select(group=g)] if installed else []
            return importlib.metadata.EntryPoints(found + list(extra))
        monkeypatch.setattr(table.importlib.metadata, "entry_points", entry_points)
        clear()
    yield use
    monkeypatch.undo()
    clear()


def test_the_built_in_drivers_come_from_the_entry_points():
    kinds = table.driver_kinds()
    assert sorted(kinds) == BUILT_IN
    for name, kind in kinds.items():
        assert isinstance(kind, DriverKind) and kind.name == name
        assert type(kind).__module__.endswith("_kind")          # each kind beside its driver
    assert [type(k).__name__ for k in table.input_kinds()] == ["AudioInputKind", "ControllerInputKind"]
    assert table.driver_origins()["simulated"] == "hapticgraph (hapticgraph.devices.simulated_kind:SimulatedKind)"


def test_a_checkout_with_stale_metadata_reads_its_pyproject(fresh):
    fresh(installed=False)
    assert sorted(table.driver_kinds()) == BUILT_IN
    assert isinstance(table.driver_kinds()["simulated"], SimulatedKind)


class Echo(DriverKind):
    name = "echo"


class Misnamed(DriverKind):
    name = "other"


class Impostor(DriverKind):
    name = "simulated"


def test_a_plugin_joins_and_a_broken_one_is_skipped_with_a_warning(fresh, capsys):
    group = table.DRIVER_GROUP
    fresh([importlib.metadata.EntryPoint("echo", f"{__name__}:Echo", group),
           importlib.metadata.EntryPoint("misnamed", f"{__name__}:Misnamed", group),
           importlib.metadata.EntryPoint("gone", "no_such_module_anywhere:Kind", group),
           importlib.metadata.EntryPoint("notakind", "os.path:join", group),
           importlib.metadata.EntryPoint("simulated", f"{__name__}:Impostor", group)])
    kinds = table.driver_kinds()
    assert sorted(kinds) == sorted(BUILT_IN + ["echo"])
    assert isinstance(kinds["simulated"], SimulatedKind)        # the built-in keeps its name
    err = capsys.readouterr().err
    assert "'misnamed'" in err and "names a kind called 'other'" in err
    assert "'gone'" in err and "failed to load: ModuleNotFoundError" in err
    assert "'notakind'" in err and "is not a DriverKind subclass" in err
    assert "takes the name of hapticgraph" in err

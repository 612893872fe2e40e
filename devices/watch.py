"""`hapticgraph play --watch`: reload the patch when its file (or a plugin file) changes, keep the
state of every unchanged block and the drivers of unchanged devices, and swap the new session in
at a block boundary; a patch with errors is reported and the old one keeps playing."""
import os
import sys
import threading

from ..graph.entries import driver_of
from ..graph.errors import PatchError
from .driver_kind import same
from .opening import open_drivers
from .table import input_kind, kinds_of


def _incoming(patch):
    into = {}
    for c in patch.connections:
        into.setdefault(c.dst.block, []).append(str(c))
    return {k: sorted(v) for k, v in into.items()}


def _state_values(prog, name):
    """The parameter values a block's state depends on: all but those its type lists in
    `keeps_state` (data it reads afresh each sample, e.g. a simulated hand's script)."""
    values = prog.block_values(name)
    skip = getattr(prog.by_name[name].cls, "keeps_state", ())
    return {k: v for k, v in values.items() if k not in skip}


def carry_state(old, new):
    """(dst, src) array pairs that give `new` (a Program) the current state of every block of
    `old` whose type, parameters and incoming connections did not change: its State slots, its
    buffers (ring buffers stay valid because the shared sample counter carries over) and its
    cells' positions and velocities, or positions now and one sample before (Program.state_views,
    between groups that remember the same things: Program.remembers). Also returns the names kept."""
    if old.rate != new.rate:
        return [], []
    into_old, into_new = _incoming(old.patch), _incoming(new.patch)
    pairs, kept = [], []
    for name in new.patch.order:
        was = old.patch.blocks.get(name)
        if was is None or was.cls is not new.patch.blocks[name].cls:
            continue
        if not same(_state_values(old, name), _state_values(new, name)):
            continue
        if into_old.get(name, []) != into_new.get(name, []):
            continue
        views_old, views_new = old.state_views(name), new.state_views(name)
        if len(views_old) != len(views_new) or old.remembers(name) != new.remembers(name):
            continue
        same_shape = [(vn, vo) for vo, vn in zip(views_old, views_new) if vo.shape == vn.shape]
        pairs += same_shape
        if len(same_shape) == len(views_new):
            kept.append(name)
    return pairs, kept


def reload_drivers(old_patch, new_patch, old_drivers, choices=None, live_input=None):
    """Drivers for `new_patch`: the running ones of devices (and audio inputs) whose driver kind
    keeps them (by default: the entry did not change); the others are opened. Returns (drivers,
    opened, the unused old ones as (name, driver) pairs)."""
    kinds, old_kinds = kinds_of(new_patch), kinds_of(old_patch)
    keep, changed_devices, changed_inputs = {}, {}, {}
    for name, spec in new_patch.devices.items():
        old = old_patch.devices.get(name)
        kind = driver_of(spec, kinds)
        if (old is not None and name in old_drivers and kind is not None
                and driver_of(old, old_kinds) is kind and kind.kept(old, spec)):
            keep[name] = old_drivers[name]
        else:
            changed_devices[name] = spec
    for inst in new_patch.blocks.values():
        feeder = input_kind(inst.cls)
        if feeder is None:
            continue
        old = old_patch.blocks.get(inst.name)
        if old is not None and inst.name in old_drivers and feeder.kept(old, inst):
            keep[inst.name] = old_drivers[inst.name]
        else:
            changed_inputs[inst.name] = inst
    view = new_patch.subset(changed_inputs.values(), devices=changed_devices)   # the part to open drivers for
    opened = open_drivers(view, {k: v for k, v in (choices or {}).items() if k in changed_devices}, live_input,
                          running=keep)
    drivers = dict(keep)
    drivers.update(opened)
    unused = [(name, d) for name, d in old_drivers.items() if drivers.get(name) is not d]
    return drivers, opened, unused


def plugin_files(patch):
    """The source files of the plugin block types a patch loaded (its `plugins:`)."""
    files = set()
    registry = patch.registry
    for name, cls in (registry.types.items() if registry is not None else ()):
        if not str(registry.origin.get(name, "")).startswith("plugin"):
            continue
        module = sys.modules.get(cls.__module__)
        path = getattr(module, "__file__", None)
        if path:
            files.add(os.path.realpath(path))
    return sorted(files)


class Watcher:
    """Polls the modification times of a patch file and of its plugin files; on a change, loads
    the new patch (`load_patch()`; an edited plugin is imported again) and hands it to the playing
    hapticgraph.Session (`player.session.swap`: compiled on this thread, applied by the audio
    callback at a block boundary, keeping the state of every unchanged block). A patch with
    errors, or a patch or plugin file that was deleted, is reported in one line and the old patch
    keeps playing."""

    def __init__(self, player, path, load_patch, interval=0.25, stream=None):
        self.player, self.path, self.load_patch = player, path, load_patch
        self.interval, self.stream = interval, stream or sys.stderr
        self.files = [os.fspath(path)] + plugin_files(player.session.patch)
        self.stamps = {f: self._mtime(f) for f in self.files}
        self.missing = set()
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._loop, name="hapticgraph-watch", daemon=True)

    @staticmethod
    def _mtime(path):
        try:
            st = os.stat(path)
            return (st.st_mtime_ns, st.st_size, st.st_ino)
        except OSError:
            return None

    def start(self):
        self.thread.start()
        return self

    def stop(self):
        self._stop.set()

    def _loop(self):
        while not self._stop.wait(self.interval):
            try:
                self.poll()
            except Exception as exc:  # noqa: BLE001 - the watcher must not die silently
                print(f"hapticgraph: --watch: {type(exc).__name__}: {exc}; still playing", file=self.stream)

    def poll(self):
        """Look at the files once; reload if one changed. True if a reload was swapped in."""
        changed, gone = [], []
        for f in self.files:
            m = self._mtime(f)
            if m == self.stamps.get(f):
                continue
            self.stamps[f] = m
            (gone if m is None else changed).append(f)
        for f in gone:
            if f not in self.missing:
                self.missing.add(f)
                what = "patch" if f == self.files[0] else "plugin"
                print(f"hapticgraph: the {what} file {os.path.basename(f)} was deleted; still playing the "
                      "previous version", file=self.stream)
        self.missing -= set(changed)
        if not changed or self.missing:
            return False
        for f in changed:
            if f != self.files[0]:
                _forget_module(f)
        ok = self.reload()
        if ok:
            self.files = [self.files[0]] + plugin_files(self.player.session.patch)
            for f in self.files:
                self.stamps.setdefault(f, self._mtime(f))
        return ok

    def reload(self):
        """Load, compile and swap in the patch; True once it plays."""
        player, name = self.player, os.path.basename(self.path)
        session = player.session
        switch = sys.getswitchinterval()
        sys.setswitchinterval(min(switch, 0.0002))   # let the audio callback in while compiling
        try:
            swap = session.swap(self.load_patch())
        except PatchError as exc:
            player.reload_errors += 1
            print(f"hapticgraph: {name} changed but has errors; still playing the previous version:",
                  file=self.stream)
            for p in exc.problems:
                print(f"  {p}", file=self.stream)
            return False
        except Exception as exc:  # noqa: BLE001 - a bad reload never stops the music
            player.reload_errors += 1
            print(f"hapticgraph: cannot reload {name}: {exc}; still playing the previous version", file=self.stream)
            return False
        finally:
            sys.setswitchinterval(switch)
        if not swap.wait(5.0):
            print("hapticgraph: reload not swapped in (the stream stopped)", file=self.stream)
            return False
        kept = swap.kept
        print(f"hapticgraph: reloaded {name} at {swap.at / session.rate:.3f} s; kept the state of {len(kept)} "
              f"block(s){': ' + ', '.join(kept) if kept else ''}", file=self.stream)
        return True


def _forget_module(path):
    """Drop the imported module of an edited plugin file, so the reload imports it afresh (the
    playing kernel keeps the functions it was compiled from)."""
    for name, module in list(sys.modules.items()):
        file = getattr(module, "__file__", None)
        if file and os.path.realpath(file) == path:
            del sys.modules[name]


__all__ = ["Watcher", "carry_state", "plugin_files", "reload_drivers"]

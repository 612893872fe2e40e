"""The files a sweep's patch reads, carried to the workers with the tasks: the patch, its plugin
files, the audio files its blocks play and its devices' files. A worker writes them once into a
folder named by their hash (in its temporary folder) and loads the patch from there, so a worker
on another machine needs neither the client's file system nor a copy made by hand; and the same
folder on every worker of one machine keeps the kernel cache's keys (which hash plugin paths) the
same for all of them."""
import hashlib
import os
import shutil
import tempfile

_ready = {}           # bundle digest -> patch path, in this process


def _read(path):
    with open(path, "rb") as f:
        return f.read()


def _paths(patch):
    """Absolute paths of every file the patch reads (the patch first)."""
    base = os.path.dirname(os.path.abspath(patch.file))
    doc = patch.doc if isinstance(patch.doc, dict) else {}
    paths = [os.path.abspath(patch.file)]
    paths += [os.path.join(base, p) for p in doc.get("plugins") or () if isinstance(p, str) and p.endswith(".py")]
    for inst in patch.blocks.values():
        paths += [os.path.join(base, inst.values[n]) for n, p in inst.cls.params.items()
                  if p.refers == "file" and inst.values.get(n)]
    paths += [os.path.join(base, spec["file"]) for spec in patch.devices.values()
              if isinstance(spec, dict) and isinstance(spec.get("file"), str)]
    return list(dict.fromkeys(os.path.normpath(p) for p in paths))


def bundle_of(patch):
    """{"patch": its path in the bundle, "files": {relative path: bytes}, "digest": sha256 of all}."""
    paths = _paths(patch)
    root = os.path.commonpath([os.path.dirname(p) for p in paths])
    files = {os.path.relpath(p, root).replace(os.sep, "/"): _read(p) for p in paths}
    h = hashlib.sha256()
    for rel in sorted(files):
        h.update(rel.encode("utf-8", "surrogatepass") + b"\0" + hashlib.sha256(files[rel]).digest())
    return {"patch": os.path.relpath(paths[0], root).replace(os.sep, "/"), "files": files,
            "digest": h.hexdigest()}


def materialize(bundle):
    """The path of the bundle's patch in this machine's temporary folder (written once, atomically)."""
    digest = bundle["digest"]
    path = _ready.get(digest)
    if path is not None:
        return path
    folder = os.path.join(_own_folder(), digest[:24])
    if not _whole(folder, bundle):
        tmp = tempfile.mkdtemp(prefix=".bundle.", dir=os.path.dirname(folder))
        try:
            for rel, data in bundle["files"].items():
                target = os.path.join(tmp, *rel.split("/"))
                os.makedirs(os.path.dirname(target), exist_ok=True)
                with open(target, "wb") as f:
                    f.write(data)
            try:
                os.rename(tmp, folder)
            except OSError:               # another worker of this machine was first, or a stale copy
                if not _whole(folder, bundle):
                    shutil.rmtree(folder, ignore_errors=True)
                    os.rename(tmp, folder)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    path = _ready[digest] = os.path.join(folder, *bundle["patch"].split("/"))
    return path


def _own_folder():
    """hapticgraph-sweep-UID in the temporary folder, made private; a private folder of its own if
    that name is taken by another user (a shared /tmp)."""
    uid = os.getuid() if hasattr(os, "getuid") else 0
    folder = os.path.join(tempfile.gettempdir(), f"hapticgraph-sweep-{uid}")
    os.makedirs(folder, mode=0o700, exist_ok=True)
    info = os.lstat(folder)
    if os.path.islink(folder) or (hasattr(os, "getuid") and (info.st_uid != uid or info.st_mode & 0o022)):
        if not _private:
            _private.append(tempfile.mkdtemp(prefix="hapticgraph-sweep-"))
        return _private[0]
    return folder


_private = []


def _whole(folder, bundle):
    """True if folder holds every file of the bundle, byte for byte."""
    try:
        return all(_read(os.path.join(folder, *rel.split("/"))) == data for rel, data in bundle["files"].items())
    except OSError:
        return False

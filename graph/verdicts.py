"""Schema verdicts: a patch document found clean against its JSON Schema, remembered in the kernel
cache folder, so that loading the same patch again does not import jsonschema (about 0.1 s of a
warm start: attrs, referencing, rpds, its format checkers) to find nothing again.

A verdict is named by the SHA-256 of the schema (assembled from the block declarations and the
driver kinds: graph/schema.py), of the document as JSON (2 and 2.0 differ, as do true and 1) and
of jsonschema's version; it holds the paths of the floats the schema took as integers, which the
check makes ints (graph/explain.py's whole_errors) and a remembered verdict makes the same ints.
Only a clean document gets one: a document with a problem is checked every time, so every message
is jsonschema's as before. A document that is not plain JSON (a key that is not text) is checked
every time, and so is every document when the cache folder is not usable (graph/kcache.py).
"""
import contextlib
import hashlib
import json
import os
import tempfile

from .cachekey import dist_version
from .explain import make_whole_at
from .kcache import cache_dir, refusal

FOLDER = "verdicts"
_PLAIN = (str, int, float, bool, type(None))


def _plain(node):
    """True if node is JSON as json.dumps writes it back (text keys, plain values)."""
    if isinstance(node, dict):
        return all(type(k) is str and _plain(v) for k, v in node.items())
    if isinstance(node, list):
        return all(_plain(v) for v in node)
    return type(node) in _PLAIN


def verdict_key(schema, doc):
    """The name of the verdict on `doc` against `schema`, or None when it cannot have one."""
    if not _plain(doc):
        return None
    try:
        text = json.dumps([schema, doc], sort_keys=True, separators=(",", ":"))
    except (TypeError, ValueError):
        return None
    h = hashlib.sha256(f"hapticgraph schema verdict 1\0{dist_version('jsonschema')}\0".encode())
    h.update(text.encode("utf-8", "surrogatepass"))
    return h.hexdigest()[:32]


def _folder():
    root = cache_dir()
    return None if refusal(root) is not None else os.path.join(root, FOLDER)


def recall(key, doc):
    """True if `doc` (named `key`) was found clean before: its floats are then made ints as the
    check made them. False: check it."""
    folder = _folder() if key is not None else None
    if folder is None:
        return False
    try:
        with open(os.path.join(folder, key + ".json"), "rb") as f:
            verdict = json.loads(f.read(1 << 20))
        made = verdict["whole"]
        if verdict.get("key") != key or not isinstance(made, list) or not all(isinstance(p, list) and p for p in made):
            return False
    except (OSError, ValueError, KeyError, TypeError):
        return False
    return make_whole_at(doc, made)


def remember(key, made):
    """Keep the verdict that the document named `key` is clean (`made`: whole_errors' paths)."""
    folder = _folder() if key is not None else None
    if folder is None:
        return
    try:
        os.makedirs(folder, mode=0o700, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".verdict.", dir=folder)
    except OSError:
        return
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump({"key": key, "whole": made}, f)
        os.replace(tmp, os.path.join(folder, key + ".json"))
    except (OSError, TypeError, ValueError):
        with contextlib.suppress(OSError):
            os.remove(tmp)


__all__ = ["recall", "remember", "verdict_key"]

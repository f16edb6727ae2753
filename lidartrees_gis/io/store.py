"""Results kept on disk and read back by a later process (``-resume``'s tiles, a run's shared
read cache) in a data format that cannot run code: a NumPy ``.npz`` read with
``allow_pickle=False``, whose arrays hold the numbers (WKB and other bytes as ``uint8`` with
offsets) and whose ``__meta__`` member is JSON describing the structure (dicts, lists, tuples,
scalars, CRSs and the dataclasses registered with :func:`register`:
:class:`~lidartrees_gis.io.chunk.PointChunk`, :class:`~lidartrees_gis.grid.GridSpec`, ...) with
each array's dtype and shape.

Reading validates everything: the format tag, each node's kind, every array's presence, dtype
(never ``object``) and shape against the description, and what the caller expects (``check``).
Any mismatch raises :class:`StoreError`; callers treat it as a file to ignore. A value of any
other type is refused when written (:class:`TypeError`), so nothing is kept that could not be
read back exactly.
"""
from __future__ import annotations

import json
import os
import tempfile
import zipfile
from dataclasses import fields

import numpy as np

#: the format tag written in every file's description
FORMAT = "lidartrees-store-1"
META = "__meta__"


class StoreError(ValueError):
    """A stored file that is damaged, foreign or not of the expected shape."""


#: the dataclasses a stored value may hold, by name (rebuilt from their fields only)
TYPES: dict = {}


def register(cls):
    """Let values of dataclass ``cls`` be stored (its fields as values); usable as a class
    decorator. A file naming a class not registered in the reading process is refused."""
    TYPES[cls.__name__] = cls
    return cls


def _register_core() -> None:
    from ..grid import GridSpec
    from .chunk import PointChunk

    for cls in (GridSpec, PointChunk):
        TYPES.setdefault(cls.__name__, cls)


class _Writer:
    def __init__(self):
        self.arrays = {}

    def array(self, a: np.ndarray) -> dict:
        key = f"a{len(self.arrays)}"
        self.arrays[key] = a
        return {"a": key, "dtype": a.dtype.str, "shape": list(a.shape)}

    def encode(self, v):
        if v is None or isinstance(v, (bool, str)):
            return v
        if isinstance(v, (int, float)) and type(v) in (int, float):
            return {"@": "int" if type(v) is int else "float", "v": repr(v)}
        if isinstance(v, np.generic):
            if v.dtype.hasobject:
                raise TypeError(f"cannot store a numpy scalar of {v.dtype}")
            return {"@": "scalar", **self.array(np.asarray(v))}
        if isinstance(v, bytes):
            return {"@": "bytes", **self.array(np.frombuffer(v, np.uint8))}
        if isinstance(v, np.ndarray):
            return self._ndarray(v)
        if isinstance(v, (list, tuple)):
            return {"@": type(v).__name__, "v": [self.encode(x) for x in v]}
        if type(v) is dict:
            return {"@": "dict", "k": [self.encode(k) for k in v],
                    "v": [self.encode(x) for x in v.values()]}
        if TYPES.get(type(v).__name__) is type(v):
            return {"@": "obj", "cls": type(v).__name__,
                    "v": {f.name: self.encode(getattr(v, f.name)) for f in fields(v)}}
        srs = _crs_text(v)
        if srs is not None:
            return {"@": "crs", "v": srs}
        raise TypeError(f"cannot store a {type(v).__name__}")

    def _ndarray(self, v: np.ndarray) -> dict:
        if not v.dtype.hasobject:
            return {"@": "nd", **self.array(v)}
        flat = v.ravel()
        if all(isinstance(x, bytes) or x is None for x in flat):  # WKB
            lens = np.array([-1 if x is None else len(x) for x in flat], np.int64)
            data = np.frombuffer(b"".join(x for x in flat if x is not None), np.uint8)
            return {"@": "bytes_array", "shape": list(v.shape), "data": self.array(data),
                    "lens": self.array(lens)}
        if all(type(x) is str for x in flat):
            return {"@": "str_array", **self.array(np.asarray(flat.tolist(), dtype=str)),
                    "shape_": list(v.shape)}
        return {"@": "object_array", "shape": list(v.shape),
                "v": [self.encode(x) for x in flat.tolist()]}


def _crs_text(v):
    """A pyproj or rasterio CRS as text it can be rebuilt from, else None."""
    kind = type(v).__module__.split(".")[0]
    if kind == "pyproj" and type(v).__name__ == "CRS":
        return {"pyproj": v.srs or v.to_wkt()}
    if kind == "rasterio" and type(v).__name__ == "CRS":
        return {"rasterio": v.to_wkt()}
    return None


def save(path, value, meta: dict | None = None) -> None:
    """Write ``value`` to ``path`` (``.npz``) with the extra JSON ``meta``; atomically (a
    temporary file beside it, renamed)."""
    _register_core()
    w = _Writer()
    tree = w.encode(value)
    desc = json.dumps({"format": FORMAT, "meta": meta or {}, "tree": tree}, allow_nan=True)
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(path)), suffix=".part")
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **w.arrays, **{META: np.frombuffer(desc.encode(), np.uint8)})
        os.replace(tmp, path)  # a reader sees all of it or none
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


class _Reader:
    def __init__(self, npz):
        self.npz, self.used = npz, set()

    def array(self, node: dict) -> np.ndarray:
        key = node.get("a")
        if not isinstance(key, str) or key not in self.npz.files or key == META:
            raise StoreError(f"array {key!r} missing")
        a = self.npz[key]  # allow_pickle=False: an object array raises ValueError
        if a.dtype.hasobject or a.dtype.str != node.get("dtype") or \
                list(a.shape) != node.get("shape"):
            raise StoreError(f"array {key}: {a.dtype.str} {list(a.shape)} where the description "
                             f"says {node.get('dtype')} {node.get('shape')}")
        self.used.add(key)
        return a

    def decode(self, node):
        if node is None or isinstance(node, (bool, str)):
            return node
        if not isinstance(node, dict) or not isinstance(node.get("@"), str):
            raise StoreError(f"unexpected node {type(node).__name__}")
        tag = node["@"]
        if tag in ("int", "float"):
            return (int if tag == "int" else float)(node["v"])
        if tag == "scalar":
            a = self.array(node)
            if a.shape != ():
                raise StoreError("a scalar of shape " + str(a.shape))
            return a[()]
        if tag == "bytes":
            return self.array(node).tobytes()
        if tag == "nd":
            return self.array(node)
        if tag in ("list", "tuple"):
            items = [self.decode(x) for x in _list(node.get("v"))]
            return items if tag == "list" else tuple(items)
        if tag == "dict":
            keys, vals = _list(node.get("k")), _list(node.get("v"))
            if len(keys) != len(vals):
                raise StoreError("a dict's keys and values differ in number")
            return {self.decode(k): self.decode(v) for k, v in zip(keys, vals)}
        if tag in ("bytes_array", "str_array", "object_array"):
            return self._object_array(tag, node)
        if tag == "obj":
            cls = TYPES.get(node.get("cls")) if isinstance(node.get("cls"), str) else None
            kw = node.get("v")
            if cls is None or not isinstance(kw, dict) or \
                    not set(kw) <= {f.name for f in fields(cls)}:
                raise StoreError(f"an object of class {node.get('cls')!r}")
            return cls(**{k: self.decode(v) for k, v in kw.items()})
        if tag == "crs":
            return _crs_from(node.get("v"))
        raise StoreError(f"unknown node {tag!r}")

    def _object_array(self, tag, node) -> np.ndarray:
        shape = node.get("shape_" if tag == "str_array" else "shape")
        if not isinstance(shape, list) or not all(isinstance(s, int) and s >= 0 for s in shape):
            raise StoreError(f"bad shape {shape!r}")
        n = int(np.prod(shape, dtype=np.int64))
        if tag == "str_array":
            a = self.array(node)
            if a.dtype.kind != "U" or a.shape != (n,):
                raise StoreError("bad string array")
            out = np.empty(n, object)
            out[:] = a.tolist()
        elif tag == "bytes_array":
            data, lens = self.array(node.get("data") or {}), self.array(node.get("lens") or {})
            if data.dtype != np.uint8 or lens.dtype != np.int64 or lens.shape != (n,) or \
                    int(lens[lens > 0].sum()) != data.size or (lens < -1).any():
                raise StoreError("bad byte array")
            raw, out, at = data.tobytes(), np.empty(n, object), 0
            for i, m in enumerate(lens.tolist()):
                if m >= 0:
                    out[i] = raw[at:at + m]
                    at += m
        else:
            items = _list(node.get("v"))
            if len(items) != n:
                raise StoreError("bad object array")
            out = np.empty(n, object)
            for i, x in enumerate(items):
                out[i] = self.decode(x)
        return out.reshape(shape)


def _list(v) -> list:
    if not isinstance(v, list):
        raise StoreError(f"expected a list, got {type(v).__name__}")
    return v


def _crs_from(v):
    if not isinstance(v, dict) or len(v) != 1 or not isinstance(next(iter(v.values())), str):
        raise StoreError("bad CRS")
    (kind, text), = v.items()
    if kind == "pyproj":
        from pyproj import CRS

        return CRS(text)
    if kind == "rasterio":
        from rasterio.crs import CRS

        return CRS.from_wkt(text)
    raise StoreError(f"unknown CRS kind {kind!r}")


def load(path, check=None):
    """Read what :func:`save` wrote: ``(value, meta)``. ``check(value, meta)`` may raise
    :class:`StoreError` for a value that is not what the caller expects. Raises
    :class:`StoreError` for anything else than a whole, valid file of this format (a pickle, a
    foreign or damaged file), OSError when it cannot be read."""
    _register_core()
    with open(path, "rb") as fh:
        if fh.read(4) != b"PK\x03\x04":
            raise StoreError("not a stored result (no .npz archive)")
        fh.seek(0)
        return _load(fh, check)


def _load(fh, check):
    """:func:`load` of an open file (read member by member, not whole into memory)."""
    try:
        with np.load(fh, allow_pickle=False) as npz:
            if META not in npz.files:
                raise StoreError("no description")
            desc = json.loads(npz[META].tobytes().decode("utf-8"))
            if not isinstance(desc, dict) or desc.get("format") != FORMAT or \
                    not isinstance(desc.get("meta"), dict):
                raise StoreError("another format")
            r = _Reader(npz)
            value = r.decode(desc.get("tree"))
            if r.used != set(npz.files) - {META}:
                raise StoreError("arrays not in the description")
    except StoreError:
        raise
    except (ValueError, KeyError, TypeError, zipfile.BadZipFile, EOFError, UnicodeError,
            RecursionError, OverflowError) as exc:
        raise StoreError(f"{type(exc).__name__}: {exc}") from None
    if check is not None:
        check(value, desc["meta"])
    return value, desc["meta"]

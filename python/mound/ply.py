"""Point clouds as binary little-endian PLY (../shared/STYLE.md: float x y z in local ENU
metres, optional uchar red green blue, a `comment mound.<kind> v1` header line)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mound.errors import InputError


def write_ply(path: str | Path, xyz: np.ndarray, rgb: np.ndarray | None = None,
              comment: str = "mound.cloud v1") -> None:
    xyz = np.asarray(xyz, dtype="<f4")
    if xyz.ndim != 2 or xyz.shape[1] != 3 or not np.all(np.isfinite(xyz)):
        raise InputError("ply: points must be a finite (n, 3) array")
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if rgb is not None:
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    data = np.empty(len(xyz), dtype=fields)
    data["x"], data["y"], data["z"] = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    if rgb is not None:
        rgb = np.asarray(rgb, dtype="u1")
        data["red"], data["green"], data["blue"] = rgb[:, 0], rgb[:, 1], rgb[:, 2]
    props = "".join(f"property {'float' if t == '<f4' else 'uchar'} {n}\n" for n, t in fields)
    header = (f"ply\nformat binary_little_endian 1.0\ncomment {comment}\n"
              f"element vertex {len(xyz)}\n{props}end_header\n").encode("ascii")
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(header + data.tobytes())
    tmp.replace(path)


# PLY scalar types (both the names of the PLY 1.0 text and the sized ones) as numpy's.
PLY_TYPES = {"char": "i1", "uchar": "u1", "short": "<i2", "ushort": "<u2", "int": "<i4",
             "uint": "<u4", "float": "<f4", "double": "<f8", "int8": "i1", "uint8": "u1",
             "int16": "<i2", "uint16": "<u2", "int32": "<i4", "uint32": "<u4",
             "float32": "<f4", "float64": "<f8"}


def read_ply(path: str | Path) -> tuple[np.ndarray, np.ndarray | None]:
    """(xyz, rgb or None) of a binary little-endian PLY of vertices with scalar
    properties (write_ply's, mound_recon's with its track_length)."""
    data = read_ply_fields(path)
    xyz = np.stack([data["x"], data["y"], data["z"]], axis=1).astype(np.float64)
    rgb = np.stack([data["red"], data["green"], data["blue"]], axis=1) \
        if "red" in data else None
    return xyz, rgb


def read_ply_fields(path: str | Path) -> dict[str, np.ndarray]:
    """Every vertex property of such a file by name (e.g. aligned.ply's `distance`)."""
    raw = Path(path).read_bytes()
    end = raw.find(b"end_header\n")
    if not raw.startswith(b"ply\n") or end < 0:
        raise InputError(f"{path}: not a PLY file")
    header = raw[:end].decode("ascii", errors="replace").splitlines()
    if "format binary_little_endian 1.0" not in header:
        raise InputError(f"{path}: only binary_little_endian 1.0 is supported")
    count = None
    fields = []
    for line in header:
        parts = line.split()
        if parts[:2] == ["element", "vertex"]:
            count = int(parts[2])
        elif parts and parts[0] == "property":
            kind = PLY_TYPES.get(parts[1])
            if kind is None:
                raise InputError(f"{path}: unsupported property type {parts[1]}")
            fields.append((parts[2], kind))
    if count is None:
        raise InputError(f"{path}: no vertex element")
    dtype = np.dtype(fields)
    body = raw[end + len(b"end_header\n"):]
    if len(body) < count * dtype.itemsize:
        raise InputError(f"{path}: truncated ({len(body)} bytes for {count} vertices)")
    data = np.frombuffer(body, dtype=dtype, count=count)
    if not {"x", "y", "z"} <= set(data.dtype.names or ()):
        raise InputError(f"{path}: the vertices lack x, y or z")
    return {name: data[name] for name in data.dtype.names or ()}


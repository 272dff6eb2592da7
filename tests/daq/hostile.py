"""A corpus of damaged and altered variants of one good session file, generated at test time (nothing stored).

Each variant is ``(name, make)``: ``make(good, out)`` writes the variant of the good file ``good`` to ``out``
(a FIFO, a folder, or any bytes). ``expect`` says what a reader must do with it:

- ``"error"``: a clear one-line error (the file is damaged or altered),
- ``"same"``: harmless change — loads with results identical to the good file's,
- ``"flagged"``: loads, but says what it is (incomplete / unsealed), so nothing is passed off as the original.
"""

from __future__ import annotations

import json
import os
import random
import shutil
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np

Make = Callable[[Path, Path], None]
PAGE = 4096


def _copy_then(edit: Callable[[h5py.File], None]) -> Make:
    def make(good: Path, out: Path) -> None:
        shutil.copyfile(good, out)
        with h5py.File(out, "a") as h5:
            edit(h5)

    return make


def _bytes_then(edit: Callable[[bytearray], bytes | bytearray]) -> Make:
    def make(good: Path, out: Path) -> None:
        out.write_bytes(bytes(edit(bytearray(good.read_bytes()))))

    return make


def _replace(name: str, data: object, dtype: object = None) -> Callable[[h5py.File], None]:
    def edit(h5: h5py.File) -> None:
        attrs = dict(h5[name].attrs)
        del h5[name]
        ds = h5.create_dataset(name, data=data, dtype=dtype)
        for k, v in attrs.items():
            ds.attrs[k] = v

    return edit


def _as(name: str, convert: Callable[[np.ndarray], object], dtype: object = None) -> Callable[[h5py.File], None]:
    def edit(h5: h5py.File) -> None:
        ds = h5[name]
        values = ds.asstr()[()] if h5py.check_string_dtype(ds.dtype) else ds[()]
        _replace(name, convert(values), dtype)(h5)

    return edit


def _delete(name: str) -> Callable[[h5py.File], None]:
    def edit(h5: h5py.File) -> None:
        del h5[name]

    return edit


def _record(name: str, change: Callable[[dict], object]) -> Callable[[h5py.File], None]:
    def edit(h5: h5py.File) -> None:
        rec = json.loads(h5[name][()])
        new = change(rec)
        text = json.dumps(rec if new is None else new, sort_keys=True)
        _replace(name, text, h5py.string_dtype())(h5)

    return edit


def _set(key: str, value: object) -> Callable[[dict], None]:
    def change(rec: dict) -> None:
        rec[key] = value

    return change


def _nested(keys: tuple[str, ...], value: object) -> Callable[[dict], None]:
    def change(rec: dict) -> None:
        d = rec
        for k in keys[:-1]:
            d = d[k]
        d[keys[-1]] = value

    return change


def _text_sub(name: str, old: str, new: str) -> Callable[[h5py.File], None]:
    def edit(h5: h5py.File) -> None:
        text = h5[name].asstr()[()]
        assert old in text, old
        _replace(name, text.replace(old, new, 1), h5py.string_dtype())(h5)

    return edit


def _cell(name: str, row: int, value: object) -> Callable[[h5py.File], None]:
    def edit(h5: h5py.File) -> None:
        h5[name][row] = value

    return edit


def _attr(name: str, value: object, where: str = "/") -> Callable[[h5py.File], None]:
    def edit(h5: h5py.File) -> None:
        h5[where].attrs[name] = value

    return edit


def _truncate(fraction: float | int) -> Make:
    def edit(b: bytearray) -> bytes | bytearray:
        n = fraction if isinstance(fraction, int) else int(len(b) * fraction)
        return b[:n]

    return _bytes_then(edit)


def _flip(seed: int, bits: int = 1) -> Make:
    def edit(b: bytearray) -> bytes | bytearray:
        rng = random.Random(seed)
        for _ in range(bits):
            i = rng.randrange(len(b))
            b[i] ^= 1 << rng.randrange(8)
        return b

    return _bytes_then(edit)


def _zero_page(index: int | float) -> Make:
    def edit(b: bytearray) -> bytes | bytearray:
        pages = len(b) // PAGE
        k = index if isinstance(index, int) else int(pages * index)
        b[k * PAGE : (k + 1) * PAGE] = bytes(min(PAGE, len(b) - k * PAGE))
        return b

    return _bytes_then(edit)


def _write(data: bytes) -> Make:
    def make(good: Path, out: Path) -> None:
        out.write_bytes(data)

    return make


def _fifo(good: Path, out: Path) -> None:
    os.mkfifo(out)


def _folder(good: Path, out: Path) -> None:
    out.mkdir()


def _foreign_hdf5(good: Path, out: Path) -> None:
    with h5py.File(out, "w") as h5:
        h5["x"] = np.arange(3)


def _extra_members(h5: h5py.File) -> None:
    h5["entry/notes"] = "added later by a colleague"
    h5["entry/summary"].create_dataset("extra_column", data=np.zeros(4))
    h5.create_group("entry/more")


def _huge_attr(name: str, where: str = "/") -> Callable[[h5py.File], None]:
    def edit(h5: h5py.File) -> None:
        h5[where].attrs.create(name, data=np.zeros(8_000, dtype="<f8"))  # 64 kB: HDF5's dense attribute storage

    return edit


def corpus() -> list[tuple[str, str, Make]]:
    """(name, expect, make) for every variant."""
    v: list[tuple[str, str, Make]] = []
    # --- truncations
    for n in (0, 8, 512, 2048):
        v.append((f"truncated-to-{n}-bytes", "error", _truncate(n)))
    for f in (0.1, 0.3, 0.5, 0.7, 0.9, 0.99):
        v.append((f"truncated-to-{f:.0%}", "error", _truncate(f)))
    # --- bit flips (seeded: the same corpus every run) and zeroed pages
    for seed in range(16):
        v.append((f"bit-flips-{seed}", "any", _flip(seed, bits=1 + seed % 4)))
    for k in (0, 1, 2, 3, 5, 8):
        v.append((f"zeroed-page-{k}", "any", _zero_page(k)))
    for f in (0.2, 0.4, 0.6, 0.8, 0.95, 0.98):  # 98 %: the group B-tree near the end, on which HDF5 loops
        v.append((f"zeroed-page-at-{f:.0%}", "any", _zero_page(f)))
    # --- dtypes and shapes
    s, r, e = "entry/summary", "entry/readings", "entry/exchanges"
    v += [
        ("mean_ohm-2d", "error", _copy_then(_as(f"{s}/mean_ohm", lambda a: np.stack([a, a], axis=1)))),
        ("mean_ohm-as-strings", "error", _copy_then(_as(f"{s}/mean_ohm", lambda a: a.astype("S32")))),
        ("weight_kg-as-strings", "error", _copy_then(_as(f"{s}/weight_kg", lambda a: a.astype("S32")))),
        ("resistance-as-strings", "error", _copy_then(_as(f"{r}/resistance_ohm", lambda a: a.astype("S32")))),
        ("block-as-float", "error", _copy_then(_as(f"{s}/block", lambda a: a.astype("f8")))),
        ("mean_ohm-as-float32", "error", _copy_then(_as(f"{s}/mean_ohm", lambda a: a.astype("f4")))),
        ("count-as-int64", "same", _copy_then(_as(f"{s}/count", lambda a: a.astype("i8")))),
        ("sha256-as-int", "error", _copy_then(_as(f"{s}/sha256", lambda a: np.arange(a.size)))),
        ("message-as-int", "error", _copy_then(_as(f"{e}/message", lambda a: np.arange(a.size)))),
        ("readings-scalar", "error", _copy_then(_replace(f"{r}/valid", 1))),
        ("start-record-as-int", "error", _copy_then(_replace("entry/start/record", 42))),
        (
            "start-record-as-array",
            "error",
            _copy_then(_replace("entry/start/record", ["{}", "{}"], h5py.string_dtype())),
        ),
        ("start-record-json-list", "error", _copy_then(_record("entry/start/record", lambda rec: [rec]))),
        (
            "start-record-not-json",
            "error",
            _copy_then(_replace("entry/start/record", "{not json", h5py.string_dtype())),
        ),
        ("stop-record-as-int", "error", _copy_then(_replace("entry/stop/record", 7))),
        ("stop-record-json-string", "error", _copy_then(_record("entry/stop/record", lambda rec: "success"))),
        ("stop-status-as-list", "error", _copy_then(_record("entry/stop/record", _set("status", ["success"])))),
        ("run-record-json-number", "error", _copy_then(_record("entry/runs/run_0/record", lambda rec: 3))),
        ("scene-text-as-bytes", "same", _copy_then(_as("entry/start/scene_text", lambda t: np.bytes_(t.encode())))),
        ("scene-text-as-int", "error", _copy_then(_replace("entry/start/scene_text", np.arange(5)))),
        ("scene-text-not-utf8", "error", _copy_then(_replace("entry/start/scene_text", np.bytes_(b"\xff\xfe[rig]")))),
        ("schema-abc", "error", _copy_then(_attr("contactrig_schema", "abc"))),
        ("schema-array", "error", _copy_then(_attr("contactrig_schema", np.arange(1000)))),
        ("schema-newer", "error", _copy_then(_attr("contactrig_schema", 99))),
        ("schema-claims-2", "error", _copy_then(_attr("contactrig_schema", 2))),
        ("huge-creator-attr", "same", _copy_then(_huge_attr("creator"))),
        ("huge-extra-attr", "same", _copy_then(_huge_attr("junk", "entry/summary"))),
    ]
    # --- members deleted or added
    for name in (
        f"{s}/mean_ohm", f"{s}/compliance", f"{s}/sha256", r, f"{r}/valid", e, f"{e}/reply", "entry/start/scene_text",
        "entry/start/record", "entry/start", "entry/runs", "entry/runs/run_0", "entry", "entry/stop/record",
    ):  # fmt: skip
        expect = "flagged" if name == "entry/stop/record" else "error"
        v.append((f"deleted-{name.replace('/', '.')}", expect, _copy_then(_delete(name))))
    v += [
        ("deleted-format-attr", "error", _copy_then(lambda h5: h5.attrs.__delitem__("contactrig_format"))),
        ("extra-members", "same", _copy_then(_extra_members)),
        ("units-changed", "same", _copy_then(_attr("units", "furlong", f"{s}/weight_kg"))),
    ]
    # --- altered records, texts and values (what the per-block SHA-256 does not cover)
    v += [
        (
            "scene-clearance",
            "error",
            _copy_then(_text_sub("entry/start/scene_text", "[rig]", "[rig]\nclearance_m = 1e-3")),
        ),
        ("scene-resistivity", "error", _copy_then(_text_sub("entry/start/scene_text", "sample = ", "sample = 'x' #"))),
        ("start-operator", "error", _copy_then(_record("entry/start/record", _set("operator", "mallory")))),
        ("start-imported", "error", _copy_then(_record("entry/start/record", _set("imported", True)))),
        (
            "start-plan-count",
            "error",
            _copy_then(_record("entry/start/record", _nested(("plan", "delta", "count"), 9))),
        ),
        (
            "start-plan-removed",
            "error",
            _copy_then(_record("entry/start/record", lambda rec: rec.pop("plan") and None)),
        ),
        ("stop-status", "error", _copy_then(_record("entry/stop/record", _set("status", "aborted")))),
        ("stop-reason", "error", _copy_then(_record("entry/stop/record", _set("reason", "\x1b]0;pwned\x07")))),
        ("stop-seal-removed", "error", _copy_then(_record("entry/stop/record", lambda rec: rec.pop("seal") and None))),
        ("run-record-altered", "error", _copy_then(_record("entry/runs/run_0/record", _set("host", "elsewhere")))),
        ("exchange-reply", "error", _copy_then(_cell(f"{e}/reply", 0, "KEITHLEY INSTRUMENTS,MODEL 9999"))),
        ("exchange-time", "error", _copy_then(_cell(f"{e}/t_s", 3, 123.0))),
        ("exchange-error-text", "error", _copy_then(_cell(f"{e}/error", 2, "boom"))),
        ("summary-started", "error", _copy_then(_cell(f"{s}/started", 0, b"1999-01-01T00:00:00+00:00"))),
        ("summary-mean", "error", _copy_then(_cell(f"{s}/mean_ohm", 1, 1.0))),
        ("reading-value", "error", _copy_then(_cell(f"{r}/resistance_ohm", 3, 1.0))),
        ("summary-first-exchange", "error", _copy_then(_cell(f"{s}/first_exchange", 2, 10**9))),
        ("summary-count-negative", "error", _copy_then(_cell(f"{s}/count", 0, -5))),
    ]
    # --- not a session at all
    v += [
        ("empty-file", "error", _write(b"")),
        ("text-file", "error", _write(b"block,weight\n1,5.44\n")),
        ("random-bytes", "error", _write(random.Random(1).randbytes(50_000))),
        ("hdf5-signature-then-zeros", "error", _write(b"\x89HDF\r\n\x1a\n" + bytes(50_000))),
        ("foreign-hdf5", "error", _foreign_hdf5),
        ("fifo", "error", _fifo),
        ("folder", "error", _folder),
    ]
    return v

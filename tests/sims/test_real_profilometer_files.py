"""Profilometer files as the outside world writes them: dropouts, text exports with a header, non-square pixels,
formats without magic bytes, maps that are not cylinders.

Two sets. Files written here in each format's own layout (always run): X3P by SurfaceTopography's writer, Gwyddion's
text export, NanoFocus NMS by the layout the library's reader declares. And SurfaceTopography's own test data from
real instruments (MIT; ``test/file_format_examples`` of github.com/ContactEngineering/SurfaceTopography), which this
repository does not carry: put them, unchanged, in ``shared/profilometer/`` (or name the folder in
``CONTACTRIG_PROFILOMETER_FILES``) and the second half of this module runs on them; see :data:`REAL`.

Every expected number is computed here independently: heights decoded by SurfaceTopography from the path (or by
NumPy from the NMS layout), the least-squares plane by ``numpy.linalg.lstsq`` on the measured points, and ISO
25178-2's definitions written out with NumPy/SciPy (Sq, Sp, Sv, Ssk, Sku over the measured points; Sdq from the
pairs of neighbours that were both measured), never contactrig's own earlier output.
"""

from __future__ import annotations

import json
import math
import os
import struct
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from contactrig.cli.main import main
from contactrig.core.scene import read_measured_map
from contactrig.core.validation import SettingError
from sims.surface import Conditioning, SurfaceSpec, condition_height_map, self_affine
from tests import surface_maker as mk

st = pytest.importorskip("SurfaceTopography", reason="SurfaceTopography (extra 'surfaces') reads the formats")

ROOT = Path(__file__).resolve().parents[2]

#: The instruments' files: name → (what it is, sha256 of the file as the library's repository holds it).
REAL = {
    "frt-2.frt": (
        "MicroProf FRT, 27 % dropouts",
        "e4de418521b4149549a750008c9127777e1ed645ab6ead87a24a404eb1a190ac",
    ),
    "sur-2.sur": (
        "Digital Surf SUR, 0.04 % dropouts",
        "44f5c6c9aa48eef4b5f5814ad231b573a36725318b9ad0c15e019881d507cfde",
    ),
    "sur-3.sur": (
        "Digital Surf SUR, 89 % dropouts",
        "33408fb02755c1f09c6f3ffc8fa1f209400d9febdb7acb67e9a1e9f4d9d55948",
    ),
    "x3p-2.x3p": (
        "X3P, 0.128 × 0.315 µm pixels",
        "a53fbeb1764a6d0d2b22d189aebc1f7372a6d1430e5bbccc3cb2cc06616ce921",
    ),
    "nms-2.nms": (
        "NanoFocus NMS",
        "99b929552e2d972430e5b84b2eace6d6378a118db238a01e71e21e87b2c94acf",
    ),
    "txt_example.txt": (
        "Gwyddion text export",
        "48d21fdbadc870cbe9af7cca321c01dbcfd9637d86fc60e22317dcdbf7f969f7",
    ),
    "gwyddion-export-english.txt": (
        "Gwyddion text export, µm and nm",
        "30ed0d800821a1d53f44c9f4b1e97c33dc59b7917c167a74be58da8e4b68a248",
    ),
}


# ---------------------------------------------------------------------------------------------------------------
# Independent references.


def library_heights_m(path: Path) -> tuple[np.ndarray, float, float]:
    """Heights in m (rows = y, NaN = not measured) and the pitches along x and y (m), read by the library itself."""
    from SurfaceTopography.Support.UnitConversion import get_unit_conversion_factor

    t = st.read_topography(str(path))
    f = get_unit_conversion_factor(t.unit, "m")
    h = np.ma.filled(np.ma.masked_invalid(t.heights()).astype(float), np.nan).T * f
    px, py = (s * f / n for s, n in zip(t.physical_sizes, t.nb_grid_pts, strict=True))
    return h, px, py


def iso_parameters(z: np.ndarray, pixel_m: float) -> dict[str, float]:
    """ISO 25178-2 parameters of ``z`` (m, NaN = not measured) after removing the least-squares plane fitted to the
    measured points, all over the measured points (Sdq: √(⟨z_x²⟩ + ⟨z_y²⟩) over measured neighbour pairs)."""
    ok = np.isfinite(z)
    yy, xx = np.nonzero(ok)
    a = np.column_stack([np.ones(yy.size), xx, yy])
    coef = np.linalg.lstsq(a, z[ok], rcond=None)[0]
    r = np.full(z.shape, np.nan)
    r[ok] = z[ok] - a @ coef
    h = r[ok]
    dx, dy = np.diff(r, axis=1), np.diff(r, axis=0)
    return {
        "Sq_m": float(np.sqrt(np.mean(h**2))),
        "Sp_m": float(h.max()),
        "Sv_m": float(-h.min()),
        "Ssk": float(stats.skew(h)),
        "Sku": float(stats.kurtosis(h, fisher=False)),
        "Sdq": float(np.sqrt(np.mean(dx[np.isfinite(dx)] ** 2) + np.mean(dy[np.isfinite(dy)] ** 2)) / pixel_m),
    }


def resampled_x(h: np.ndarray, px: float, py: float) -> np.ndarray:
    """Rows of ``h`` (x at ``px``) linearly interpolated at the coarser pitch ``py`` (numpy.interp)."""
    x_new = np.arange(math.floor((h.shape[1] - 1) * px / py) + 1) * py
    return np.array([np.interp(x_new, np.arange(h.shape[1]) * px, row) for row in h])


def nms_heights_um(path: Path) -> np.ndarray:
    """NanoFocus NMS decoded with NumPy: uint16 rows after the 3468-byte header, scaled between zmin and zmax."""
    raw = path.read_bytes()
    zmin, zmax = struct.unpack_from("<dd", raw, 16)
    nx, ny = struct.unpack_from("<II", raw, 1368)
    v = np.frombuffer(raw, dtype="<u2", count=nx * ny, offset=mk.NMS_HEADER).reshape(ny, nx)
    return v / (2**16 - 2) * (zmax - zmin) + zmin


def surface_json(capsys, *args: str) -> dict:
    assert main(["surface", *args, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def refused(capsys, *args: str) -> str:
    assert main(["surface", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    return err


def assert_iso(got: dict, expected: dict) -> None:
    for key, value in expected.items():
        assert got[key] == pytest.approx(value, rel=1e-9, abs=1e-15), key


def rough(ny: int, nx: int, pixel_m: float, seed: int = 3) -> np.ndarray:
    """A non-periodic rough map (m): a corner of a generated self-affine surface, Sq ≈ 0.3 µm."""
    n = 2 * max(ny, nx)
    return self_affine(n, pixel_m=pixel_m, sq_m=0.3e-6, hurst=0.8, seed=seed)[:ny, :nx]


def with_dropouts(z: np.ndarray, fraction: float, seed: int = 5) -> np.ndarray:
    out = z.copy()
    out.flat[np.random.default_rng(seed).permutation(z.size)[: round(fraction * z.size)]] = np.nan
    return out


# ---------------------------------------------------------------------------------------------------------------
# Files written here in each format's layout.


@pytest.mark.parametrize(("fraction", "limit"), [(0.31, 0.35), (0.89, 0.9)])
def test_max_missing_fraction_reaches_every_pass(tmp_path, capsys, fraction, limit):
    """An X3P with 31 % / 89 % dropouts: refused by default naming the option, read with it (the mean-plane pass
    too), every statistic of the measured points."""
    z = with_dropouts(rough(48, 64, 2e-6), fraction)
    path = mk.write(tmp_path / "dropouts.x3p", z, 2e-6)
    err = refused(capsys, str(path))
    assert "max_missing_fraction = 0.05" in err and f"{int(np.isnan(z).sum())} of {z.size}" in err
    out = surface_json(capsys, str(path), "--max-missing-fraction", str(limit))
    assert out["info"]["missing_points"] == int(np.isnan(z).sum())
    h, px, _ = library_heights_m(path)
    assert_iso(out["before"], iso_parameters(h, px))


def test_statistics_are_of_the_measured_points_only(tmp_path, capsys):
    """2 % dropouts: the filled points would change Sdq; neither the command nor the spec's Sq and moments use them."""
    z = with_dropouts(rough(64, 64, 2e-6), 0.02)
    path = mk.write(tmp_path / "map.x3p", z, 2e-6)
    h, px, _ = library_heights_m(path)
    out = surface_json(capsys, str(path), "--lambda-c-m", "60e-6")
    assert_iso(out["before"], iso_parameters(h, px))
    spec = SurfaceSpec.from_table("surface", {"kind": "file"}, h, metadata={"pixel_m": px, "height_unit_m": 1.0})
    assert spec.missing is not None and int(spec.missing.sum()) == int(np.isnan(h).sum())
    measured = iso_parameters(spec.measured_points(), px)
    assert iso_parameters(np.asarray(spec.measured), px)["Sdq"] != pytest.approx(measured["Sdq"], rel=1e-3)
    assert spec.sq_m == pytest.approx(measured["Sq_m"], rel=1e-9)
    assert math.sqrt(2 * spec.moments().m2) == pytest.approx(measured["Sdq"], rel=0.02)  # x/y averaged


def test_a_text_export_with_a_header_gives_its_pixel_size(tmp_path, capsys):
    """Gwyddion's text export ('# Width: 32 µm' over 16 columns): the header's pixel and unit, not 'no pixel size'."""
    z = rough(16, 16, 2e-6)
    path = mk.write_gwyddion_text(tmp_path / "export.txt", z, 2e-6)
    out = surface_json(capsys, str(path))
    assert out["info"]["pixel_m"] == pytest.approx(2e-6, rel=1e-6)
    assert out["info"]["height_unit_m"] == 1.0
    assert_iso(out["before"], iso_parameters(np.loadtxt(path), 2e-6))
    m = read_measured_map(mk.write_gwyddion_text(tmp_path / "rect.txt", z, 2e-6, 5e-6), key="FILE")
    assert m.pixel_m == pytest.approx(2e-6, rel=1e-6) and m.pixel_y_m == pytest.approx(5e-6, rel=1e-6)


def test_a_plain_grid_with_a_comment_is_still_a_plain_grid(tmp_path):
    p = tmp_path / "grid.txt"
    p.write_text("# measured on Monday\n" + "1 2 3 4 5 6 7 8\n" * 8)
    m = read_measured_map(p, key="FILE")
    assert m.pixel_m is None and m.file_format == "plain text"


def test_non_square_pixels_are_resampled_to_square_ones_and_said(tmp_path, capsys):
    """An X3P at 0.128 µm × 0.315 µm: x resampled to 0.315 µm by linear interpolation (numpy.interp here)."""
    px, py = 0.128e-6, 0.315e-6
    path = mk.write(tmp_path / "rect.x3p", rough(40, 128, px) * 0.1, px, "m", pixel_y_m=py)
    h, px_file, py_file = library_heights_m(path)
    out = surface_json(capsys, str(path))
    assert out["info"]["pixel_m"] == pytest.approx(py, rel=1e-9)
    assert "128 × 40 → 52 × 40" in out["info"]["resampled"]
    assert_iso(out["before"], iso_parameters(resampled_x(h, px_file, py_file), py_file))
    assert main(["surface", str(path)]) == 0
    assert "resampled:   non-square pixels" in capsys.readouterr().out


def test_an_nms_file_is_read_by_its_suffix(tmp_path, capsys):
    """NMS has no magic bytes: from memory the library took it for a MATLAB file (IndexError). Its reader is chosen by
    the suffix; a spacing the library makes a 0.3125 m pixel is refused naming pixel_m, --pixel-m reads it."""
    z_um = 1e6 * rough(40, 48, 0.3125e-6) * 0.1 + 7.0
    held = mk.write_nms(tmp_path / "confocal.nms", z_um, 312.5)
    err = refused(capsys, str(tmp_path / "confocal.nms"))
    assert "pixel_m" in err and "confocal.nms" in err and "0.3125 m" in err and "IndexError" not in err
    out = surface_json(capsys, str(tmp_path / "confocal.nms"), "--pixel-m", "0.3125e-6")
    assert out["info"]["file_format"] == "NanoFocus NMS" and out["info"]["points"] == [40, 48]
    np.testing.assert_allclose(nms_heights_um(tmp_path / "confocal.nms"), held, rtol=1e-12)
    assert_iso(out["before"], iso_parameters(held * 1e-6, 0.3125e-6))
    mk.write_nms(tmp_path / "plain.nms", z_um, 0.3125e-3)  # a spacing the library makes 0.3125 µm
    assert surface_json(capsys, str(tmp_path / "plain.nms"))["info"]["pixel_m"] == pytest.approx(0.3125e-6)


def test_a_cylinder_the_field_does_not_resolve_is_refused(tmp_path, capsys):
    """A flat rough map with --form cylinder: refused naming form (it gave radii of millimetres to 10¹³ m). The same
    roughness on a bore of R = 2 mm (sagitta 2.6 µm over 0.2 mm, 9× the Sq): R recovered to 1 %."""
    z = rough(100, 100, 2e-6)
    err = refused(capsys, str(mk.write(tmp_path / "flat.x3p", z, 2e-6)), "--form", "cylinder")
    assert "form = 'cylinder'" in err and "does not resolve a cylinder" in err
    c = Conditioning(form="cylinder")
    _, record = condition_height_map(z + mk.bore(100, 100, 2e-6, 2e-3), pixel_m=2e-6, height_unit_m=1.0, conditioning=c)
    assert record["cylinder_radius_m"] == pytest.approx(2e-3, rel=0.01)
    sagitta = 2e-3 - math.sqrt(2e-3**2 - (99e-6) ** 2)
    assert record["cylinder_sagitta_m"] == pytest.approx(sagitta, rel=0.02)
    with pytest.raises(SettingError, match=r"form = 'cylinder'.*does not resolve"):
        condition_height_map(z, pixel_m=2e-6, height_unit_m=1.0, conditioning=c)


# ---------------------------------------------------------------------------------------------------------------
# The instruments' own files, where they are laid out (not carried by this repository).


def _real_folder() -> Path | None:
    for folder in (os.environ.get("CONTACTRIG_PROFILOMETER_FILES"), ROOT / "shared" / "profilometer",
                   ROOT.parent / "shared" / "profilometer"):  # fmt: skip
        if folder and Path(folder).is_dir():
            return Path(folder)
    return None


def real(name: str) -> Path:
    """The instrument's file ``name`` where it is laid out (its checksum checked), else the test is skipped."""
    import hashlib

    folder = _real_folder()
    what, sha = REAL[name]
    if folder is None or not (folder / name).is_file():
        pytest.skip(f"{name} ({what}, SurfaceTopography's test data) is not laid out: see the module docstring")
    assert hashlib.sha256((folder / name).read_bytes()).hexdigest() == sha, f"{folder / name} is not the original"
    return folder / name


@pytest.mark.parametrize(("name", "limit"), [("frt-2.frt", 0.3), ("sur-3.sur", 0.9)])
def test_real_maps_with_many_dropouts(capsys, name, limit):
    path = real(name)
    h, px, _ = library_heights_m(path)
    err = refused(capsys, str(path))
    assert f"{int(np.isnan(h).sum())} of {h.size} points missing" in err and "max_missing_fraction" in err
    out = surface_json(capsys, str(path), "--max-missing-fraction", str(limit))
    assert out["info"]["missing_points"] == int(np.isnan(h).sum())
    assert_iso(out["before"], iso_parameters(h, px))


def test_real_sur_map_statistics_ignore_its_filled_points(capsys):
    """0.04 % dropouts: filled, they raise Sdq by 6 %; the command's Sdq is the measured points' (numpy)."""
    path = real("sur-2.sur")
    h, px, _ = library_heights_m(path)
    out = surface_json(capsys, str(path))
    assert_iso(out["before"], iso_parameters(h, px))
    spec = SurfaceSpec.from_table("surface", {"kind": "file"}, h, metadata={"pixel_m": px, "height_unit_m": 1.0})
    assert iso_parameters(np.asarray(spec.measured), px)["Sdq"] / out["before"]["Sdq"] > 1.05


def test_real_text_exports_give_their_pixel_size():
    m = read_measured_map(real("txt_example.txt"), key="FILE")  # '# Width: 1.0e-6 m' (6 columns), 3 rows
    assert m.heights.shape == (3, 6) and m.pixel_m == pytest.approx(1.0e-6 / 6, rel=1e-12) and m.pixel_y_m is None
    assert m.heights[0, 0] * m.height_unit_m == pytest.approx(1.0e-7, rel=1e-12)
    m = read_measured_map(real("gwyddion-export-english.txt"), key="FILE")  # '12.34 µm' × '5678.9 nm'
    assert m.heights.shape == (4, 3)
    assert m.pixel_m == pytest.approx(12.34e-6 / 3, rel=1e-12) and m.pixel_y_m == pytest.approx(5678.9e-9 / 4)


def test_real_non_square_x3p_is_resampled(capsys):
    path = real("x3p-2.x3p")
    h, px, py = library_heights_m(path)
    out = surface_json(capsys, str(path))
    assert out["info"]["pixel_m"] == pytest.approx(py, rel=1e-12)
    assert "650 × 650 → 264 × 650" in out["info"]["resampled"]
    assert_iso(out["before"], iso_parameters(resampled_x(h, px, py), py))


def test_real_nms_file(capsys):
    path = real("nms-2.nms")
    assert "pixel_m" in refused(capsys, str(path))
    out = surface_json(capsys, str(path), "--pixel-m", "0.3125e-6")
    assert_iso(out["before"], iso_parameters(nms_heights_um(path) * 1e-6, 0.3125e-6))


def test_real_flat_map_is_not_a_cylinder(capsys):
    err = refused(capsys, str(real("frt-2.frt")), "--max-missing-fraction", "0.3", "--form", "cylinder")
    assert "does not resolve a cylinder" in err


def test_real_sur_map_is_compared_by_the_bem_at_full_resolution(tmp_path, capsys):
    """Issue 28, target 3: the 484 × 563 Digital Surf map, both bodies, mirrored to a 968 × 1126 periodic cell (not
    square, not cropped), through ``compare-models``: the BEM reference at every pressure, finite, the area rising."""
    from importlib import resources

    from contactrig.core.scene import load_scene
    from sims.bem_database import composite_from_config
    from sims.config import SimConfig

    path = real("sur-2.sur")
    h, _, _ = library_heights_m(path)
    text = resources.files("contactrig").joinpath("scenes/measured.toml").read_text(encoding="utf-8")
    for name in ("liner", "piston"):
        text = text.replace(f'"measured/{name}.x3p"', json.dumps(path.as_posix()))
    scene = tmp_path / "sur2.toml"
    scene.write_text(text.replace('form = "cylinder"', 'form = "plane"'), encoding="utf-8")
    z, _ = composite_from_config(SimConfig.from_scene(load_scene(scene)))
    assert z.shape == (2 * h.shape[0], 2 * h.shape[1]) and z.shape[0] != z.shape[1]
    code = main(["compare-models", str(scene), "--models", "greenwood_tripp", "--pressures", "1e5,1e6,1e7",
                 "--jobs", "1", "--json", "--quiet"])  # fmt: skip
    captured = capsys.readouterr()
    assert code == 0, captured.err
    ref = json.loads(captured.out)["reference"]
    area = ref["area_fraction"]
    assert len(area) == 3 and 0.0 < area[0] < area[1] < area[2] <= 1.0
    assert all(math.isfinite(v) and v > 0.0 for v in ref["mean_gap_m"] + ref["stiffness_pa_per_m"])

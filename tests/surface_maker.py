"""Known surfaces written as real profilometer files, for the reader, form and filter tests and the example scene.

Each surface has a closed form (a tilted plane, a bore's cylinder section of known radius, a sinusoid, a generated
self-affine roughness on a cylinder); files are written with SurfaceTopography's own writers (X3P, GWY, NetCDF)
or NumPy's (NPY, which carries no pixel size or unit). Heights are returned as ``z[row = y, column = x]`` in metres.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from sims.surface import self_affine


def grid(ny: int, nx: int, pixel_m: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(x, y) coordinates in m of a ny × nx map (rows = y)."""
    yy, xx = np.mgrid[0:ny, 0:nx]
    return xx * pixel_m, yy * pixel_m


def tilted_plane(ny: int, nx: int, pixel_m: float, sx: float = 1e-3, sy: float = -2e-3) -> NDArray[np.float64]:
    x, y = grid(ny, nx, pixel_m)
    return sx * x + sy * y + 1e-6


def bore(ny: int, nx: int, pixel_m: float, radius_m: float, axis: str = "x") -> NDArray[np.float64]:
    """A bore seen from inside (concave): its axis runs along x (columns) or y (rows), centred on the map."""
    x, y = grid(ny, nx, pixel_m)
    u = y if axis == "x" else x
    u0 = 0.5 * float(u.max())
    return radius_m - np.sqrt(radius_m**2 - (u - u0) ** 2)


def sinusoid(ny: int, nx: int, pixel_m: float, wavelength_m: float, amplitude_m: float) -> NDArray[np.float64]:
    x, _ = grid(ny, nx, pixel_m)
    return amplitude_m * np.sin(2 * np.pi * x / wavelength_m)


def liner(n: int = 160, pixel_m: float = 8e-6, radius_m: float = 0.0425, sq_m: float = 0.4e-6) -> NDArray[np.float64]:
    """A measured liner: self-affine roughness (H = 0.8, roll-off at a quarter box) on the bore's cylinder with
    a small tilt along the axis, 0.5 % optical dropouts (NaN) at fixed random points."""
    rough = self_affine(n, pixel_m=pixel_m, sq_m=sq_m, hurst=0.8, rolloff_m=n * pixel_m / 4, seed=7)
    x, _ = grid(n, n, pixel_m)
    z = bore(n, n, pixel_m, radius_m) + rough + 2e-4 * x
    rng = np.random.default_rng(3)
    z[rng.random(z.shape) < 0.005] = np.nan
    return z


def write(
    path: Path, z_m: NDArray[np.float64], pixel_m: float, unit: str = "um", pixel_y_m: float | None = None
) -> Path:
    """Write ``z_m`` (m, rows = y; 1-D: a profile) at ``pixel_m`` (along x; ``pixel_y_m`` along y, default the same)
    in ``unit`` with the format of ``path``'s suffix."""
    from SurfaceTopography import Topography, UniformLineScan
    from SurfaceTopography.Support.UnitConversion import get_unit_conversion_factor

    f = get_unit_conversion_factor("m", unit)
    h = np.ma.masked_invalid(z_m * f)
    if z_m.ndim == 1:
        t = UniformLineScan(h, physical_sizes=z_m.size * pixel_m * f, unit=unit)
    else:
        ny, nx = z_m.shape
        py = pixel_m if pixel_y_m is None else pixel_y_m
        t = Topography(h.T, physical_sizes=(nx * pixel_m * f, ny * py * f), unit=unit)  # library: [x, y]
    writer = {".x3p": t.to_x3p, ".gwy": t.to_gwy, ".nc": t.to_netcdf}[path.suffix]
    writer(str(path))
    return path


def piston(n: int = 128, pixel_m: float = 8e-6, radius_m: float = 0.04245, sq_m: float = 0.3e-6) -> NDArray[np.float64]:
    """A measured piston skirt: Gaussian roughness (λ = 64 µm) on a convex cylinder section, no dropouts."""
    from sims.surface import gaussian

    rough = gaussian(n, pixel_m=pixel_m, sq_m=sq_m, correlation_m=64e-6, seed=11)
    return -bore(n, n, pixel_m, radius_m) + rough


#: The packaged example (contactrig/scenes/measured.toml): 128 × 128 points at 8 µm (1.02 mm square), X3P in m.
EXAMPLE = {"liner.x3p": lambda: liner(n=128), "piston.x3p": piston}
EXAMPLE_PIXEL_M = 8e-6


def write_example(folder: Path) -> list[Path]:
    """Write the example scene's two X3P files into ``folder`` (how contactrig/scenes/measured/ was made)."""
    return [write(folder / name, make(), EXAMPLE_PIXEL_M, "m") for name, make in EXAMPLE.items()]


def write_gwyddion_text(path: Path, z_m: NDArray[np.float64], pixel_m: float, pixel_y_m: float | None = None) -> Path:
    """Write ``z_m`` (m, rows = y) as Gwyddion's "ASCII data matrix" export with its metadata header: ``# Channel``,
    ``# Width`` and ``# Height`` (the field in µm), ``# Value units: m``, then tab-separated rows."""
    ny, nx = z_m.shape
    py = pixel_m if pixel_y_m is None else pixel_y_m
    head = f"# Channel: Height\n# Width: {nx * pixel_m * 1e6:.6g} µm\n# Height: {ny * py * 1e6:.6g} µm\n"
    rows = "\n".join("\t".join(f"{v:.6e}" for v in row) for row in z_m)
    path.write_text(head + "# Value units: m\n" + rows + "\n", encoding="utf-8")
    return path


#: NanoFocus NMS (the layout SurfaceTopography's reader declares): a 3468-byte header (a version block at 0, the
#: z range at 16, point counts and spacing at 1368), the heights as uint16 rows scaled between zmin and zmax (µm),
#: then one byte a point (as in the instrument files we saw).
NMS_HEADER = 3468


def write_nms(path: Path, z_um: NDArray[np.float64], spacing: float) -> NDArray[np.float64]:
    """Write ``z_um`` (µm, rows = y) as a NanoFocus NMS file with ``spacing`` in the header's x and y spacing fields
    (SurfaceTopography reads them as mm; an instrument file we saw holds 312.5 there); returns the heights
    the file holds (µm, quantised to its 16 bits)."""
    import struct

    ny, nx = z_um.shape
    zmin, zmax = float(np.min(z_um)), float(np.max(z_um))
    counts = np.rint((z_um - zmin) / (zmax - zmin) * (2**16 - 2)).astype("<u2")
    head = bytearray(NMS_HEADER)
    struct.pack_into("<IIIHH", head, 0, 2, 1, 0, 0xFFFF, 0)
    struct.pack_into("<dd", head, 16, zmin, zmax)
    head[0x20:0x29] = b"OM_MS_2.0"
    head[0x34:0x49] = b"Confocal Height Image"
    struct.pack_into("<IIdd", head, 1368, nx, ny, spacing, spacing)
    path.write_bytes(bytes(head) + counts.tobytes() + bytes(nx * ny))
    return counts / (2**16 - 2) * (zmax - zmin) + zmin

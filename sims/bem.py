"""Periodic FFT boundary elements (BEM): normal contact of a rough surface with an elastic half-space.

The problem: a rigid-equivalent rough surface with composite heights ``z`` (m, ny×nx: rows along y × columns along
x, both even, not necessarily equal; periodic; square pixels of pitch ``pixel_m`` on both axes) is pressed onto a
flat elastic half-space of composite modulus ``E_star`` (Pa, 1/E* = (1−ν₁²)/E₁ + (1−ν₂²)/E₂).
Heights point *towards* the half-space: the highest points of ``z`` touch first. With u the elastic surface
displacement (m, positive into the half-space, zero mean) and h₀ the rigid-body separation of the mean planes
(m), the gap is

    g(x) = u(x) − z(x) + h₀ + mean(z),        g ≥ 0,  p ≥ 0,  p·g = 0  (Signorini conditions).

Elasticity, periodic (one tile of an infinite periodic array; Westergaard 1939, Stanley & Kato 1997):

    p_q = (E*·|q|/2)·u_q      for every wave vector q ≠ 0 (rad/m);  the q = 0 mode is the mean pressure, with u
                              of zero mean, so that the mean gap is ū = mean(g) = h₀ (all lengths in m).

On the ny×nx cell the wave vectors are q = 2π·(rfftfreq(nx, Δ), fftfreq(ny, Δ)), |q| = 2π·sqrt(fx² + fy²): the
periodic cell is nx·Δ by ny·Δ, so a rectangular map (a profilometer's, after its edges are mirrored) needs no
cropping.

This is checked against Westergaard's solution (full contact of z = Δ cos(2πx/λ) at p* = πE*Δ/λ) in the tests.

Solver: Polonsky & Keer, Wear 231 (1999) 206, constrained conjugate gradients on the pressure, either for a
prescribed mean pressure (their load-controlled algorithm: the offset h₀ is the Lagrange multiplier of the load,
the mean gap over the contact set) or a prescribed rigid-body position (mean gap ū or approach δ). An
elastic–perfectly-plastic surface layer caps the local pressure at the hardness H (0 ≤ p ≤ H): the CG acts on the
points with 0 < p < H; points at p = H may penetrate (plastic flattening) and are released when their gap opens,
as in Almqvist, Sahlin, Larsson & Lundberg, Tribol. Int. 40 (2007) 574 and ContactMechanics' hardness option.
All arithmetic is dimensionless inside: lengths in ℓ = rms(z − mean z), pressures in E*ℓ/Δ (Δ = pixel), so the
kernel 2/(|q|Δ) depends on the grid's shape only and is computed once per grid (cached).

Preconditioner (issue 28): the search direction is the gap on the free points filtered by the stiffness |q|Δ/2 (the
inverse of the compliance on the whole grid) and restricted to them again — the FFT preconditioner of Vollebregt,
J. Comput. Phys. 257 (2014) 333 — which takes the iteration count at 1024² on the benchmark surface from 93 to 34
and keeps it from growing like √n; ``precondition=False`` restores the plain directions. The filter runs in float32
(it only shapes the direction; the gaps, the step, the residual and the displacement are float64: the same
iteration counts as a float64 filter at 1024² and 2048², the same fields within the tolerance). The step length
τ = (g·t)/(t·Ct) takes t·Ct from the direction's half spectrum by Parseval's theorem, so an iteration in which no
point changes its set needs one inverse FFT for the displacement, and one that changes the set recomputes it from
the pressures (exact, no drift): about 2.4 real FFT pairs per iteration with the preconditioner, 1.3–1.5 without.

Hardware: the solver is written once over an array namespace (:mod:`sims.bem_backend`: NumPy with ``scipy.fft``
and ``workers`` threads on the CPU, CuPy on an NVIDIA GPU, ``device``), float64 on both (the filter excepted).
On the CPU the element-wise passes over the whole grid (the products with the symbols, the curvature, the
displacement update, the overlap search) run in cache-sized blocks of rows on the same ``workers`` threads, in
place, several operations per block (:meth:`sims.bem_backend.Backend.rows`); the work on the contact points alone
(≈ 6 % of the grid) stays serial.
The fields do not depend on the thread count (the blocks depend on the grid's shape only).
On the GPU every value read on the host (a dot product as a float, a branch on it, a count) waits for the card; the
iterations there run in groups of up to ``_CHECK_EVERY`` (4) with their scalars kept on the card. A branch that the
iteration almost never takes (a non-descent direction, zero curvature, no step, a breakdown, a load that cannot be
met) is assumed not taken and its test kept; the host reads the group's residuals and those tests' values in one
copy and decides as it would have one by one: at the first residual within the tolerance it goes back to that
iteration (its pressures are kept) and finishes as before; a rare branch, a NaN or a stall sends it back to the
group's start, to run those iterations with its own decisions. The iteration count, the fields and the diagnostics
are those of the iteration at which convergence is detected, as without groups (bit-identical on NumPy). Each group
ends with the next iteration's measure, and its size follows the residual's rate, so that it ends where convergence
is expected: at most 4 iterations (usually none) are computed in vain where convergence is detected. What remains
read every iteration is the size of the sets (the points that join the contact, the support, and a clipping test
when no point joins: 2.75 reads per iteration with an elastic solid against 15.3 before, 9.5 with a hardness against
22.3). On an H200 (2026-11-27) the groups made a solve 11 % faster at 1024², 23 % at 4096² and 3 % at 8192²;
three passes fused into CuPy kernels made it 2–4× slower and were taken out (docs: Benchmarks).

Convergence: the residual is the largest violation of the contact conditions in units of rms(z): |g| on points with
0 < p < H, −g on points with p = 0, +g on points with p = H (the load, in pressure control, is met exactly).
A solution is accepted only after the displacement has been recomputed from the pressure by FFT (no drift).

Public API:

* :func:`solve_contact` — one solution (mean pressure, mean gap or approach prescribed) → :class:`ContactResult`.
* :func:`solve_load_path` — a ramp of mean pressures with warm starts and the interfacial stiffness K = −dp̄/dū
  (finite differences, or the tangent on the contact set: :mod:`sims.bem_stiffness`).
* :func:`refine` — Fourier (zero-padding) interpolation of a periodic, band-limited surface onto a finer grid.
* :func:`convergence_check` — the same problem on the grid and on a refined grid, and the relative area change.
* :func:`full_contact_pressure` — the elastic mean pressure at which contact becomes complete.
* :func:`contact_spots` — periodic connected-component analysis of a contact mask (spots and their areas).

Areas: the real area fraction is the fraction of grid points with p > 0. Counting points overestimates the area by
about half a pixel along the contact perimeter; Yastrebov, Anciaux & Molinari, Tribol. Int. 114 (2017) 161 correct
it with the perimeter measured by counting contact/non-contact neighbour pairs:

    A_corrected = A_count − (π − 1 + ln 2)/24 · M · Δ²,

with M the number of contact/non-contact edges between 4-neighbours (both directions, periodic), i.e. the
"staircase" perimeter P = M·Δ.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from types import ModuleType
from typing import Any, Literal

import numpy as np
import scipy.fft as sfft
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage, optimize

from contactrig.core.validation import SettingError, check_choice, check_int, check_range
from sims.bem_backend import Backend, get_backend

__all__ = [
    "STATUS_BREAKDOWN",
    "STATUS_CONVERGED",
    "STATUS_MAX_ITERATIONS",
    "YASTREBOV_FACTOR",
    "ContactResult",
    "ContactSummary",
    "ConvergenceCheck",
    "LoadPathResult",
    "contact_spots",
    "convergence_check",
    "full_contact_pressure",
    "refine",
    "solve_contact",
    "solve_load_path",
]

#: Perimeter correction of the counted contact area, (π − 1 + ln 2)/24 (Yastrebov et al. 2017).
YASTREBOV_FACTOR = (math.pi - 1.0 + math.log(2.0)) / 24.0

STATUS_CONVERGED = 0
STATUS_MAX_ITERATIONS = 1
STATUS_BREAKDOWN = 2

_MAX_N = 16384
_RESTART_FRACTION = 0.01
_STALL_ITERATIONS = 200
_CUT_RTOL = 1e-3  # the cold start's mean pressure, relative: the start scales it to the load (_cut_full_contact)
_CUT_BELOW = 0.5  # the cut start up to p̄ = 0.5 H (measured better to 0.58 H); the uniform start above
_STALLED = -1
_CHECK_EVERY = 4  # iterations run with their decisions on the device between two reads on the host (GPU)
_Array = NDArray[np.float64]
_Index = NDArray[np.intp]


# ---------------------------------------------------------------------------------------------------------------
# Results.


@dataclass(frozen=True, eq=False)
class ContactSummary:
    """Scalars of one contact solution (SciPy ``OptimizeResult`` style: ``success``, ``status``, ``message``, ``nit``).

    Attributes:
        mean_pressure: mean contact pressure over the whole box, Pa (= force / box area).
        mean_gap: ū, mean of the gap field, m (the mean separation of the deformed surfaces).
        approach: δ, rigid-body approach since first touch, m: how far the rigid surface has moved towards the
            half-space since its highest point touched the undeformed surface, δ = max z − mean z − h₀ with h₀ the
            separation of the mean planes (for an elastic solid h₀ = ū, so dδ = −dū).
        area_fraction: points with p > 0 over all points, in [0, 1].
        area_fraction_corrected: perimeter-corrected area fraction (Yastrebov et al. 2017, see module doc), ≥ 0.
        perimeter_m: staircase perimeter M·Δ of the contact (all spots, whole box), m.
        n_spots: contact spots (4-connected, merged across the periodic boundary).
        spot_areas: areas of the spots, m², largest first.
        plastic_fraction: points at the hardness (p = H) over all points; 0 without a hardness.
        full_contact_pressure: elastic mean pressure at which the contact becomes complete, Pa (see
            :func:`full_contact_pressure`).
        nit: conjugate-gradient iterations.
        residual: largest violation of the contact conditions in units of rms(z) (see module doc).
        success: ``status == 0``.
        status: 0 converged (including exact full/no-contact solutions), 1 iteration limit, 2 numerical breakdown.
        message: what happened, in words.
        mode: ``"pressure"`` (mean pressure prescribed) or ``"gap"`` (mean gap or approach prescribed).
        n, shape, pixel_m, E_star, hardness: the grid (n: points along x, the columns, i.e. the side of a square grid;
            shape: (ny, nx), rows × columns; pixel_m: the pitch on both axes, m), composite modulus (Pa), hardness
            (Pa) or None.
        workers: FFT threads used.
        device: ``"cpu"`` or ``"gpu"``: where the arrays lived (:mod:`sims.bem_backend`).
    """

    mean_pressure: float
    mean_gap: float
    approach: float
    area_fraction: float
    area_fraction_corrected: float
    perimeter_m: float
    n_spots: int
    spot_areas: _Array
    plastic_fraction: float
    full_contact_pressure: float
    nit: int
    residual: float
    success: bool
    status: int
    message: str
    mode: str
    n: int
    shape: tuple[int, int]
    pixel_m: float
    E_star: float
    hardness: float | None
    workers: int
    device: str

    def summary(self) -> ContactSummary:
        """The scalars alone (drops the ny×nx fields of a :class:`ContactResult`)."""
        names = ContactSummary.__dataclass_fields__
        return ContactSummary(**{k: getattr(self, k) for k in names})


@dataclass(frozen=True, eq=False)
class ContactResult(ContactSummary):
    """One contact solution: the scalars of :class:`ContactSummary` and the ny×nx fields (read-only arrays).

    Attributes:
        pressure: contact pressure p, Pa, in [0, H].
        gap: gap g ≥ 0, m; exactly 0 where p > 0 (its solver value there is below ``residual``·rms(z)).
        displacement: elastic surface displacement u, m, positive into the half-space, zero mean.
        plastic_depth: where p = H, the plastic flattening −(u − z + h₀) ≥ 0, m; zero elsewhere; ``None`` without
            a hardness.
    """

    pressure: _Array
    gap: _Array
    displacement: _Array
    plastic_depth: _Array | None


@dataclass(frozen=True, eq=False)
class LoadPathResult:
    """A ramp of mean pressures (see :func:`solve_load_path`).

    Attributes:
        pressures: the prescribed mean pressures, Pa.
        mean_gap: ū at each pressure, m.
        area_fraction: real area fraction at each pressure.
        stiffness: interfacial stiffness K = −dp̄/dū at each pressure, Pa/m.
        stiffness_method: ``"centred"``, ``"forward"``, ``"path"`` or ``"tangent"`` (see :func:`solve_load_path`).
        results: one entry per pressure: :class:`ContactResult` if ``keep_fields`` else :class:`ContactSummary`.
        nit: CG iterations of every solve, the stiffness steps (or the tangent's linear solves) included.
        success: every solve converged.
    """

    pressures: _Array
    mean_gap: _Array
    area_fraction: _Array
    stiffness: _Array
    stiffness_method: str
    results: tuple[ContactSummary, ...]
    nit: int
    success: bool


@dataclass(frozen=True, eq=False)
class ConvergenceCheck:
    """The same contact on a grid and on a Fourier-refined grid (see :func:`convergence_check`).

    Attributes:
        coarse, fine: the two solutions (scalars).
        factor: refinement factor (fine pixel = coarse pixel / factor).
        relative_area_change: (A_fine − A_coarse)/A_fine of the counted area fraction.
        relative_corrected_area_change: the same for the perimeter-corrected area fraction.
    """

    coarse: ContactSummary
    fine: ContactSummary
    factor: int
    relative_area_change: float
    relative_corrected_area_change: float


# ---------------------------------------------------------------------------------------------------------------
# The periodic half-space in dimensionless form: lengths / ℓ, in-plane lengths / Δ, pressures / (E* ℓ / Δ).


class _Kernel:
    """The symbols of the periodic half-space for an ny×nx grid (``shape``, square pixels), as arrays of the
    namespace ``xp`` (made where they are used: on the GPU, on the card, nothing copied), made once per grid and
    namespace (:func:`_kernel`).

    Compliance 2/(|q|Δ) and stiffness |q|Δ/2 in ``rfft2`` layout (0 at q = 0), a float32 stiffness (the
    preconditioner filters float32 spectra) and the Parseval weights, all *interleaved*, ny × (nx + 2): each value
    twice, for the real and the imaginary part of a half spectrum viewed as real numbers, so that a product with a
    symbol is a real, contiguous multiply (no complex cast: 2–3× faster than complex × real in NumPy). The weights are
    such that their sum against the squared parts is Σₓ t·(C t) (Parseval's theorem): C(q)/(ny·nx), twice for the
    columns that stand for two modes. ``self_compliance``: the compliance of one point, the mean of the kernel over the
    full (not half) spectrum.

    Wave vectors in units of 1/Δ: along the rows (axis 0, y, full spectrum) q_y Δ = 2π·fftfreq(ny), along the columns
    (axis 1, x, half spectrum) q_x Δ = 2π·rfftfreq(nx); |q|Δ = hypot(q_y Δ, q_x Δ). The cell is ny·Δ by nx·Δ.
    """

    def __init__(self, shape: tuple[int, int], xp: ModuleType = np) -> None:
        ny, nx = shape
        q_y = 2.0 * np.pi * xp.fft.fftfreq(ny)  # axis 0 (rows): the full spectrum
        q_x = 2.0 * np.pi * xp.fft.rfftfreq(nx)  # axis 1 (columns): the half spectrum
        q = xp.hypot(q_y[:, None], q_x[None, :])
        q[0, 0] = 1.0
        compliance = 2.0 / q
        compliance[0, 0] = 0.0
        q *= 0.5
        q[0, 0] = 0.0
        weight = xp.full(q_x.size, 2.0)  # columns of the half spectrum that stand for two modes
        weight[0] = 1.0
        if nx % 2 == 0:
            weight[-1] = 1.0
        weighted = compliance * weight[None, :]
        self.self_compliance = float(weighted.sum()) / (ny * nx)
        weighted /= ny * nx
        symbols = [xp.repeat(a, 2, axis=1) for a in (compliance, q, q.astype(xp.float32), weighted)]
        if xp is np:
            for arr in symbols:
                arr.setflags(write=False)
        self.shape = (ny, nx)
        self.compliance: Any = symbols[0]
        self.stiffness: Any = symbols[1]
        self.stiffness32: Any = symbols[2]
        self.parseval: Any = symbols[3]


@lru_cache(maxsize=4)
def _kernel(shape: tuple[int, int], xp: ModuleType = np) -> _Kernel:
    return _Kernel(shape, xp)


def _dot(xp: ModuleType, a: Any, b: Any, keep: bool = False) -> Any:
    """a·b of two flat arrays: on the CPU ``einsum`` (no BLAS threads, which spin against the FFT's on a busy
    machine); on another namespace ``vdot`` (cuBLAS on the GPU: CuPy's ``einsum`` costs 0.5 ms a call there).
    A float, or with ``keep`` the value as it comes (on the GPU a 0-d array on the card: not waited for)."""
    d = np.einsum("i,i->", a, b) if xp is np else xp.vdot(a, b)
    return d if keep else float(d)


def _weighted_square_sum(xp: ModuleType, weight: Any, parts: Any, keep: bool = False) -> Any:
    """Σ weight·parts² over two equal-shaped arrays (one pass with ``einsum`` on the CPU; elsewhere a product and
    ``vdot``); a float, or with ``keep`` the value as it comes."""
    d = np.einsum("ij,ij,ij->", weight, parts, parts) if xp is np else xp.vdot((weight * parts).ravel(), parts.ravel())
    return d if keep else float(d)


def _residual(free: float, overlap: float, release: float) -> float:
    """The residual from its terms: max |g| on the free points, min g on the overlapping ones, max g on the released
    ones (each 0 where there are none)."""
    return max(free, -overlap, release)


def _below_unloaded(w: Any, p: Any, level: Any) -> Any:
    """Where w < level and p ≤ 0 (a boolean array)."""
    return (w < level) & (p <= 0.0)


class _Operator:
    """The periodic half-space on one backend: convolutions with the compliance or the stiffness, flat ny·nx arrays.

    Every element-wise pass over an ny×nx field or its half spectrum goes through :meth:`Backend.rows` (cache-sized
    blocks on the ``workers`` threads; the operations on one block fused), in place where the result allows.
    """

    def __init__(self, shape: tuple[int, int], backend: Backend) -> None:
        self.shape = shape
        self.nx = shape[1]
        self.be = backend
        self.xp = backend.xp
        self.kernel = _kernel(shape, backend.xp)
        k = self.kernel
        self.compliance, self.stiffness, self.stiffness32, self.parseval = (
            k.compliance,
            k.stiffness,
            k.stiffness32,
            k.parseval,
        )

    def rows(self, fn: Any) -> list[Any]:
        """``fn(rows)`` over the blocks of rows (:meth:`Backend.rows`)."""
        return self.be.rows(fn, self.shape[0], self.nx)

    def apply(self, x: Any, symbol: Any) -> Any:
        """irfft2(symbol · rfft2(x)) for a flat ny·nx array (float64, or float32 with a float32 symbol); a new flat
        array of the same precision."""
        spectrum = self.be.rfft2(x.reshape(self.shape))
        parts = spectrum.view(symbol.dtype)
        self.rows(lambda r: self.xp.multiply(parts[r], symbol[r], out=parts[r]))
        return self.be.irfft2(spectrum, self.shape).reshape(-1)

    def displacement_minus(self, p: Any, z: Any) -> Any:
        """u − z with u = C p (flat ny·nx arrays): one FFT pair, the subtraction in place; a new flat array."""
        w = self.apply(p, self.compliance)
        w2, z2 = w.reshape(self.shape), z.reshape(self.shape)
        self.rows(lambda r: self.xp.subtract(w2[r], z2[r], out=w2[r]))
        return w

    def curvature(self, t: Any, keep: bool = False) -> tuple[Any, Any]:
        """(C·T with T = rfft2(t), t·Ct): the step's curvature by Parseval's theorem, before any inverse FFT.

        One pass over the half spectrum: each block's share of the curvature, then the block multiplied by C. A float,
        or with ``keep`` the value as it comes (see _dot)."""
        xp = self.xp
        spectrum = self.be.rfft2(t.reshape(self.shape))
        parts = spectrum.view(xp.float64)

        def block(r: slice) -> Any:
            share = _weighted_square_sum(xp, self.parseval[r], parts[r], keep)
            xp.multiply(parts[r], self.compliance[r], out=parts[r])
            return share

        shares = self.rows(block)
        return spectrum, shares[0] if len(shares) == 1 else math.fsum(shares)

    def add_step(self, spectrum: Any, tau: Any, w: Any) -> Any:
        """w − τ·C t from C·T (:meth:`curvature`): one inverse FFT and one fused pass; ``w`` itself, updated in
        place."""
        xp = self.xp
        ct = self.be.irfft2(spectrum, self.shape)
        w2 = w.reshape(self.shape)

        def block(r: slice) -> None:
            xp.multiply(ct[r], -tau, out=ct[r])
            xp.add(w2[r], ct[r], out=w2[r])

        self.rows(block)
        return w

    def below(self, w: Any, level: Any, p: Any = None) -> Any:
        """Flat indices where w < level (and, with ``p``, p ≤ 0), in order (one pass, the blocks in parallel; on the
        GPU one read of the count).

        With ``p`` both tests are made on each block before its indices are listed (the points below ``level``
        include about half the contact, those with p ≤ 0 too only the few that join it): the same indices as
        listing the first and filtering them, in one pass, on the CPU as on the GPU."""
        xp = self.xp
        if not self.be.fast:
            return xp.flatnonzero(_below_unloaded(w, p, level) if p is not None else w < level)
        w2 = w.reshape(self.shape)
        p2 = p.reshape(self.shape) if p is not None else None

        def block(r: slice) -> Any:
            mask = w2[r] < level
            if p2 is not None:
                mask &= p2[r] <= 0.0
            return xp.flatnonzero(mask) + (r.start or 0) * self.nx

        parts = self.rows(block)
        return parts[0] if len(parts) == 1 else xp.concatenate(parts)


# ---------------------------------------------------------------------------------------------------------------
# Validation.


def _check_surface(z: ArrayLike) -> NDArray[np.float64]:
    try:
        arr = np.asarray(z, dtype=np.float64)
    except (TypeError, ValueError):
        raise SettingError("z", type(z).__name__, "expected a 2-D array of heights in m") from None
    if arr.ndim != 2:
        raise SettingError("z", f"array of shape {arr.shape}", "expected a 2-D ny×nx array of heights in m")
    if any(k < 4 or k > _MAX_N or k % 2 for k in arr.shape):
        raise SettingError("z", f"array of shape {arr.shape}", f"expected even ny and nx in [4, {_MAX_N}] (FFT layout)")
    if not np.all(np.isfinite(arr)):
        raise SettingError("z", "array with NaN or inf", "expected finite heights in m")
    return arr


def _check_workers(workers: int | None) -> int:
    if workers is None:
        return os.cpu_count() or 1
    return check_int("workers", workers, 1, 4096)


def _check_hardness(hardness: float | None) -> float | None:
    if hardness is None:
        return None
    return check_range("hardness", hardness, 0.0, None, lo_open=True, unit="Pa")


# ---------------------------------------------------------------------------------------------------------------
# ---------------------------------------------------------------------------------------------------------------
# The Polonsky–Keer constrained conjugate gradient.


def _max(a: Any, default: float) -> float:
    """max(a), or ``default`` for an empty array (CuPy's max has no ``initial``)."""
    return float(a.max()) if a.size else default


def _min(a: Any, default: float) -> float:
    return float(a.min()) if a.size else default


def _capped_scale(xp: ModuleType, values: Any, total: float, target: float, cap: float) -> Any | None:
    """min(s·values, cap) with the s that makes the sum equal ``target`` (Newton from below); None if impossible.
    ``total``: the sum of ``values``. Each Newton step reads two numbers on the host (the count below the cap, with
    the indices, and their sum)."""
    if total <= 0.0 or target > cap * values.size:
        return None
    s = target / total
    for _ in range(100):
        below = xp.flatnonzero(s * values < cap)
        below_sum = float(values[below].sum())
        f = s * below_sum + cap * float(values.size - below.size)
        if f >= target * (1.0 - 1e-15) or below_sum <= 0.0:
            break
        s += (target - f) / below_sum
    out = s * values
    xp.minimum(out, cap, out=out)
    return out if float(out.sum()) >= target * (1.0 - 1e-12) else None


def _place(a: Any, old: Any, idx: Any, values: Any) -> None:
    """a ← ``values`` at ``idx`` and 0 at the other points of ``old`` (a's nonzero points).

    A large ``old`` (over 1/8 of the grid, the first iterations) is cleared by one fill: cheaper than a scatter."""
    if old.size > a.size // 8:
        a.fill(0.0)
    else:
        a[old] = 0.0
    a[idx] = values


@dataclass
class _Measure:
    """The state of the contact conditions at the start of an iteration (dimensionless, backend arrays)."""

    free: Any  # 0 < p < H (indices)
    g_free: Any  # gap there
    sat: Any  # p = H
    opened: Any  # saturated points whose gap has opened (mask over sat)
    g_release: Any
    overlap: Any  # p = 0 and penetrating
    g_overlap: Any
    residual: Any  # a float, or while speculative its three terms (_residual)

    @property
    def release(self) -> Any:
        return self.sat[self.opened] if self.sat.size else self.sat


@dataclass
class _Mark:
    """The solver's state at the start of an iteration, enough to go back to it (:meth:`_Solver._back`): the support
    and its pressures, the search direction on its points, the scalars, and (at the start of a group of speculative
    iterations) the displacement. The filter's input needs nothing: it is rewritten whole from the free points."""

    nit: int
    supp: Any
    p: Any
    t_supp: Any
    t: Any
    scalars: tuple[Any, ...]  # conjugate, g_old, tau, gain, exact, h0
    w: Any = None


class _Solver:
    """Constrained CG of Polonsky & Keer (1999) with an optional pressure cap, dimensionless, flat ny·nx arrays.

    ``load`` (sum of the pressures, i.e. ny·nx·p̄) prescribes the mean pressure; otherwise ``offset`` (h₀ − mean z in
    units of ℓ) prescribes the rigid-body position. ``w`` holds u − z; the gap is w + h₀. ``precondition``: the
    search direction comes from the gap filtered by the stiffness E*|q|/2 (see :func:`solve_contact`).
    """

    def __init__(
        self,
        z: Any,
        op: _Operator,
        *,
        load: float | None,
        offset: float,
        hardness: float,
        tol: float,
        max_iter: int,
        precondition: bool = True,
    ) -> None:
        xp = op.xp
        self.xp = xp
        self.op = op
        self.z = z
        self.kernel = op.kernel
        self.workers = op.be.workers
        self.load = load
        self.cap = hardness
        self.tol = tol
        self.max_iter = max_iter
        self.precondition = precondition
        size = z.size
        self.p = xp.zeros(size)
        self.w = xp.empty(size)
        self.t = xp.zeros(size)  # the search direction on the free points, zero elsewhere
        self.g32 = xp.zeros(size, dtype=xp.float32)  # the gap on the free points, zero elsewhere: the filter's input
        self.g32_supp: Any = xp.empty(0, dtype=xp.int64)
        self.mask = xp.empty(size, dtype=bool)
        self.supp: Any = xp.empty(0, dtype=xp.int64)
        self.t_supp: Any = xp.empty(0, dtype=xp.int64)
        self.conjugate = False
        self.g_old = 0.0
        self.tau = 1.0 / self.kernel.self_compliance  # pressure per unit gap given to points that join
        self.gain = 1.0
        self.nit = 0
        self.exact = False
        self.residual: Any = math.inf
        self.h0: Any = offset
        self.defer = op.be.defer  # speculate: decisions on the device, read in groups (GPU; see run)
        self.lazy = False  # inside a group of speculative iterations
        self.pending: list[tuple[Callable[..., bool], tuple[Any, ...]]] = []  # rare-branch tests, speculative
        self.group = _CHECK_EVERY  # the next group's size
        self.seen: list[tuple[int, float]] = []  # (iteration, residual) read on the host
        self.carried: _Measure | None = None  # the measure that ended the last group: the next one's first

    # -- decisions on the device (GPU) --------------------------------------------------------------------------

    def _num(self, x: Any) -> Any:
        """A scalar of the iteration: as it comes while speculative (on the GPU a 0-d array, not waited for), else a
        float."""
        return x if self.lazy else float(x)

    def _rare(self, test: Callable[..., bool], *values: Any) -> bool:
        """Whether to take a branch that the iteration almost never takes: ``test(*values)``; while speculative,
        False, and the test and its values (0-d device arrays) are kept for the host, which reads the values with
        the group's residuals, applies the test as here and, where it holds, runs the iteration again with its own
        decisions (:meth:`_speculate`): no work on the device and no wait."""
        if not self.lazy:
            return test(*values)
        self.pending.append((test, values))
        return False

    def _mark(self, whole: bool) -> _Mark:
        """The state now (with ``whole``, a copy of the displacement too)."""
        scalars = (self.conjugate, self.g_old, self.tau, self.gain, self.exact, self.h0)
        w = self.w.copy() if whole else None
        return _Mark(self.nit, self.supp, self.p[self.supp], self.t_supp, self.t[self.t_supp], scalars, w)

    def _back(self, mark: _Mark) -> None:
        """Back to ``mark``'s state; its displacement if it has one, else the caller recomputes it."""
        _place(self.p, self.supp, mark.supp, mark.p)
        _place(self.t, self.t_supp, mark.t_supp, mark.t)
        self.supp, self.t_supp, self.nit = mark.supp, mark.t_supp, mark.nit
        self.conjugate, self.g_old, self.tau, self.gain, self.exact, self.h0 = mark.scalars
        if mark.w is not None:
            self.w = mark.w

    def _read(self, values: list[Any]) -> list[float]:
        """``values`` (numbers, or 0-d arrays of the namespace) as floats, those on the device in one copy."""
        xp = self.xp
        on_device = [i for i, v in enumerate(values) if xp is not np and isinstance(v, xp.ndarray)]
        out = [math.nan if xp is not np and isinstance(v, xp.ndarray) else float(v) for v in values]
        if on_device:
            host = self.op.be.to_host(xp.stack([values[i].astype(xp.float64, copy=False) for i in on_device]))
            for i, v in zip(on_device, host.tolist(), strict=True):
                out[i] = v
        return out

    def _speculate(self, best: float, best_at: int, watch_stall: bool) -> tuple[float, int, int]:
        """Up to ``self.group`` iterations with their decisions on the device and the measure that follows them, then
        one read of their residuals and rare-branch notes on the host; returns (best, best_at, eager) as :meth:`run`
        keeps them.

        ``eager`` = 0: every iteration stands as the host would have run it (each residual above ``tol``, no stall,
        no rare branch); the last measure is kept for the next group. Else the next ``eager`` iterations are run
        with host decisions: at the first residual within ``tol``, 1, the state that iteration's (the group's end
        as it is; an earlier one from its mark: its pressures, the displacement recomputed, or the solution
        finalised, as the host does on seeing such a residual); at a rare branch, a NaN or a stall, the state back at
        the group's start and the iterations up to that one.
        """
        k = min(self.group, self.max_iter - self.nit)
        carried, self.carried = self.carried, None
        if k < 1:
            return best, best_at, 1
        start, start_best, start_best_at = self._mark(whole=True), best, best_at
        try:
            marks, m, values = self._group(k, start, carried)
        except Exception:  # a state gone wrong after a rare branch: the host runs the group (and raises if it must)
            self._back(start)
            return best, best_at, k
        for j in range(k + 1):
            r = values[j]
            if r <= self.tol:
                self._converged_at(marks[j] if j < k else None)
                return best, best_at, 1
            if j == k:
                self.carried = m
                self._plan(values[: k + 1], start.nit)
                return best, best_at, 0
            if math.isnan(r) or values[k + 1 + j]:
                break
            if r < 0.5 * best:
                best, best_at = r, start.nit + j
            elif watch_stall and start.nit + j - best_at >= _STALL_ITERATIONS:
                break
        self._back(start)
        return start_best, start_best_at, j + 1

    def _converged_at(self, mark: _Mark | None) -> None:
        """The state as the host holds it on seeing a residual within ``tol``: ``mark``'s (None: the state now), its
        displacement recomputed (exactly as it was if it was exact), or the solution finalised if it was not."""
        if mark is not None:
            self._back(mark)
            if self.exact:
                self._recompute()
        if not self.exact:
            self.finalise()

    def _group(self, k: int, start: _Mark, carried: _Measure | None) -> tuple[list[_Mark], _Measure, list[float]]:
        """``k`` speculative iterations from ``start`` (the first measure ``carried`` over if given) and the measure
        after them: (the marks at their starts, that last measure, and as read on the host in one copy, the k + 1
        residuals followed by k flags, 1.0 where an iteration needed a rare branch)."""
        marks: list[_Mark] = []
        residuals: list[Any] = []
        tests: list[list[tuple[Callable[..., bool], tuple[Any, ...]]] | None] = []
        self.lazy = True
        try:
            with np.errstate(all="ignore"):
                for j in range(k + 1):
                    marks.append(self._mark(whole=False) if marks else start)
                    m = carried if j == 0 and carried is not None else self.measure()
                    residuals.append(m.residual)
                    if j == k:
                        break
                    self.pending = []
                    self.nit += 1
                    tests.append(self.pending if self.step(m) else None)
        finally:
            self.lazy = False
        flat = [v for terms in residuals for v in terms] + [v for t in tests if t for _, vals in t for v in vals]
        values = iter(self._read(flat))
        out = [_residual(next(values), next(values), next(values)) for _ in residuals]
        for t in tests:
            read = [(test, [next(values) for _ in vals]) for test, vals in t] if t is not None else None
            out.append(float(read is None or any(test(*vals) for test, vals in read)))
        return marks, m, out

    def _plan(self, residuals: list[float], nit: int) -> None:
        """The next group's size: the iterations the residual needs to reach ``tol`` at the rate of the last ones
        read, at most ``_CHECK_EVERY``, so that few are computed past convergence."""
        self.seen += [(nit + j, r) for j, r in enumerate(residuals) if not self.seen or nit + j > self.seen[-1][0]]
        (i0, r0), (i1, r1) = self.seen[-2] if len(self.seen) > 1 else self.seen[-1], self.seen[-1]
        self.group = _CHECK_EVERY
        if i1 > i0 and 0.0 < r1 < r0 and self.tol < r1:
            needed = math.log(self.tol / r1) / math.log(r1 / r0) * (i1 - i0)
            self.group = max(1, min(_CHECK_EVERY, math.ceil(needed)))

    # -- state -----------------------------------------------------------------------------------------------

    def start(self, p0: Any) -> None:
        """Initial pressures (flat, ≥ 0): scaled to the load if prescribed, capped, displacement computed."""
        supp = self.xp.flatnonzero(p0 > 0.0)
        self._set_support(supp, p0[supp])
        if self.load is not None and not self._rescale():
            # the reset orders the points by their displacement: that of the initial pressures (before, w was
            # still the uninitialised buffer here, so a warm start that could not carry the load depended on
            # whatever memory it got: different iterations and fields, within tol, from run to run)
            self._recompute()
            self._plastic_reset()
        self._recompute()

    def _set_support(self, idx: Any, values: Any) -> None:
        _place(self.p, self.supp, idx, values)
        self.supp = idx

    def _recompute(self) -> None:
        self.w = self.op.displacement_minus(self.p, self.z)
        self.exact = True

    def _rescale(self) -> bool:
        """Scale the pressures to the load; False if the support cannot carry it below the hardness.

        Without a cap all support pressures are scaled. With a cap, the points at H stay there (they leave only when
        their gap opens) and the free points are scaled by s with min(s·p, H) (Newton on this concave, piecewise
        linear sum, from below: exact in a few steps); if the saturated points alone exceed the load, all are scaled.
        """
        assert self.load is not None
        values = self.p[self.supp]
        if not math.isfinite(self.cap):
            total = values.sum()
            if self.lazy:
                self._rare(lambda t: t <= 0.0, total)
            else:
                total = float(total)
                if total <= 0.0:
                    return False
            self.p[self.supp] = values * (self.load / total)
            return True
        xp = self.xp
        free = xp.flatnonzero(~(values >= self.cap))  # one read on the host: the others are at H
        target = self.load - self.cap * float(values.size - free.size)
        free_vals = values[free]
        total = float(free_vals.sum())
        if target <= 0.0 or total <= 0.0:
            free, free_vals, target, total = xp.arange(values.size), values, self.load, float(values.sum())
        scaled = _capped_scale(xp, free_vals, total, target, self.cap)
        if scaled is None:
            return False
        values[free] = scaled
        self.p[self.supp] = values
        return True

    def _plastic_reset(self) -> None:
        """Load control with every loaded point at H: H on the most penetrating points, the rest on the next one."""
        assert self.load is not None
        xp = self.xp
        count = min(int(self.load // self.cap), self.z.size - 1)
        rest = self.load - count * self.cap
        order = xp.argpartition(self.w, count)[: count + 1] if count + 1 < self.z.size else xp.arange(self.z.size)
        order = order[xp.argsort(self.w[order])]
        values = xp.full(order.size, self.cap)
        values[-1] = rest
        keep = values > 0.0
        self._set_support(order[keep], values[keep])
        self.conjugate = False

    # -- one iteration ---------------------------------------------------------------------------------------

    def _split(self) -> tuple[Any, Any]:
        """(free points 0 < p < H, saturated points p = H) of the support."""
        if not math.isfinite(self.cap):
            return self.supp, self.xp.empty(0, dtype=self.supp.dtype)
        at_cap = self.p[self.supp] >= self.cap
        return self.supp[~at_cap], self.supp[at_cap]

    def _offset_all_saturated(self, sat: Any) -> float:
        """Load control with no free point: an h₀ with g ≥ 0 off the support and g ≤ 0 on it, if there is one."""
        self.mask.fill(True)
        self.mask[self.supp] = False
        lo = -_min(self.w[self.mask], math.inf)
        hi = -_max(self.w[sat], -math.inf)
        if math.isfinite(lo) and lo <= hi:
            return 0.5 * (lo + hi)
        return hi if math.isfinite(hi) else self.h0

    def measure(self) -> _Measure:
        """Active sets, gaps and the residual of the current state; sets h₀ in load control."""
        xp = self.xp
        free, sat = self._split()
        g_free = self.w[free]
        if self.load is not None:
            self.h0 = -self._num(g_free.mean()) if free.size else self._offset_all_saturated(sat)
        h0 = self.h0
        g_free += h0
        overlap = self.op.below(self.w, -h0, self.p)  # off the support (p > 0 exactly on it); one pass
        g_overlap = self.w[overlap]
        g_overlap += h0
        g_sat = self.w[sat]
        g_sat += h0
        opened = g_sat > 0.0
        g_release = g_sat[opened] if sat.size else g_sat
        if self.lazy:  # its terms, left on the device: the host reads them with the group's
            residual: Any = (xp.abs(g_free).max() if free.size else 0.0, g_overlap.min() if overlap.size else 0.0,
                             g_release.max() if g_release.size else 0.0)  # fmt: skip
        else:
            residual = _residual(_max(xp.abs(g_free), 0.0), _min(g_overlap, 0.0), _max(g_release, 0.0))
        self.residual = residual
        return _Measure(free, g_free, sat, opened, g_release, overlap, g_overlap, residual)

    def _direction(self, m: _Measure) -> Any:
        """The (preconditioned) CG search direction on the free points (mean-free in load control), in ``self.t``.

        Preconditioned: the gap on the free points is filtered by the stiffness E*|q|/2 (the inverse of the
        compliance on the whole grid) and restricted to them again, s = P K P g, a symmetric positive semi-definite
        preconditioner on the free set (Vollebregt, J. Comput. Phys. 257 (2014) 333); β = (s·g)/(s_old·g_old).
        """
        xp = self.xp
        t_old = self.t[m.free] if self.conjugate else None
        if self.precondition and m.free.size:
            _place(self.g32, self.g32_supp, m.free, m.g_free)
            self.g32_supp = m.free
            s = self.op.apply(self.g32, self.op.stiffness32)[m.free].astype(xp.float64)
        else:
            s = m.g_free.copy()
        if self.load is not None and s.size:
            s -= s.mean()
        lazy = self.lazy  # speculative: the scalars stay on the device, the rare branches are noted (_rare)
        g_new = _dot(xp, s, m.g_free, lazy)
        if self.precondition:  # pressure per unit gap of the filtered gradient: scales the points that join
            gg = _dot(xp, m.g_free, m.g_free, lazy)
            self.gain = 1.0 if self._rare(lambda a, b: not (a > 0.0 and b > 0.0), gg, g_new) else g_new / gg
        t_free = s.copy()
        if t_old is not None and not self._rare(lambda g: not g > 0.0, self.g_old):
            t_old *= g_new / self.g_old
            t_free += t_old
            if self.load is not None:
                t_free -= t_free.mean()
        if self._rare(lambda d: d <= 0.0, _dot(xp, t_free, m.g_free, lazy)):  # not a descent direction: restart
            t_free = s if g_new > 0.0 else m.g_free - (m.g_free.mean() if self.load is not None else 0.0)
            g_new = _dot(xp, t_free, m.g_free)
        self.g_old = g_new
        _place(self.t, self.t_supp, m.free, t_free)
        self.t_supp = m.free
        return t_free

    def _bounds_step(self, m: _Measure, t_free: Any) -> float:
        """Zero curvature: t = 0, or a uniform t over the whole grid under displacement control, where the energy is
        linear along t; go to the bounds (a uniform penetration can only be taken up plastically)."""
        p_free = self.p[m.free]
        down, up = t_free > 0.0, t_free < 0.0
        to_zero = _max(p_free[down] / t_free[down], 0.0)
        to_cap = _max((p_free[up] - self.cap) / t_free[up], 0.0)  # +inf without a cap: no step (as before)
        tau = max(to_zero, to_cap)
        return tau if math.isfinite(tau) else 0.0

    def step(self, m: _Measure) -> bool:
        """One CG step with projection onto [0, H], overlap/release update and load balance; False on breakdown.

        FFT work: the direction's spectrum gives the step length by Parseval (:meth:`_Operator.curvature`);
        when no point changes its set the displacement is updated from it (one inverse FFT, one fused pass), else it
        is recomputed from the new pressures (one FFT pair: exact, no drift).
        """
        xp = self.xp
        spectrum: Any = None
        tau = 0.0
        p_free = self.p[m.free]
        if m.free.size:
            t_free = self._direction(m)
            spectrum, curvature = self.op.curvature(self.t, self.lazy)
            if self.lazy:  # zero curvature, breakdown or no step: rare, left to the host (see run)
                tau = _dot(xp, m.g_free, t_free, True) / curvature
                self._rare(lambda c, t: not (c > 0.0 and math.isfinite(t) and t > 0.0), curvature, tau)
            else:
                tau = _dot(xp, m.g_free, t_free) / curvature if curvature > 0.0 else self._bounds_step(m, t_free)
                if not math.isfinite(tau):
                    return False
            if self.lazy or tau > 0.0:
                self.tau = tau * self.gain
                t_free *= tau
                p_free -= t_free
            else:
                spectrum = None
        changed = self._project(m, p_free)
        p_over = xp.minimum(-self.tau * m.g_overlap, self.cap)
        p_rel = xp.clip(self.cap - self.tau * m.g_release, 0.0, self.cap)
        self._assemble(m, p_free, p_over, p_rel)
        # Polonsky & Keer restart the CG whenever points join the contact; restarting only when many join (more than
        # RESTART_FRACTION of the free points) keeps the conjugacy through the trickle of single points near the end,
        # which is most of the iterations: 2.7× fewer at 1024² (173 → 63), the same converged area.
        self.conjugate = m.overlap.size + m.g_release.size <= _RESTART_FRACTION * m.free.size
        if changed or spectrum is None:
            if self.load is not None and not self._rescale():
                self._plastic_reset()
            self._recompute()
        else:
            self.w = self.op.add_step(spectrum, tau, self.w)
            self.exact = False
        return not self._rare(lambda h: not math.isfinite(h), self.h0)

    def _project(self, m: _Measure, p_free: Any) -> bool:
        """p_free clipped to [0, H] in place; whether any point changes its set (clipped, joining or released)."""
        xp = self.xp
        joined = m.overlap.size > 0 or m.g_release.size > 0
        if self.lazy and joined:  # the set changes anyway: clipping the points inside [0, H] leaves them as they are
            clipped = True
        elif self.lazy:  # one read
            clipped = bool(xp.any((p_free <= 0.0) | (p_free >= self.cap)))
        else:
            clipped = bool(xp.any(p_free <= 0.0)) or bool(xp.any(p_free >= self.cap))
        if clipped:
            xp.clip(p_free, 0.0, self.cap, out=p_free)
        return clipped or joined

    def _assemble(self, m: _Measure, p_free: Any, p_over: Any, p_rel: Any) -> None:
        xp = self.xp
        kept_sat = m.sat[~m.opened] if m.g_release.size else m.sat
        idx = xp.concatenate([m.free, kept_sat, m.release, m.overlap])
        val = xp.concatenate([p_free, xp.full(kept_sat.size, self.cap), p_rel, p_over])
        keep = val > 0.0
        if self.lazy:  # one read of the count
            sel = xp.flatnonzero(keep)
            idx, val = idx[sel], val[sel]
        elif not bool(keep.all()):
            idx, val = idx[keep], val[keep]
        self._set_support(idx, val)

    def finalise(self) -> None:
        """Exact load and displacement for the returned state (one more FFT pair)."""
        if self.load is not None and not self._rescale():
            self._plastic_reset()
        self._recompute()

    def run(self) -> int:
        """Iterate to ``tol`` (exact check on a recomputed displacement); returns the status.

        Load control with a cap can stall: when nearly all the load sits at H, h₀ (the mean gap over the few free
        points) is ill-determined and the released points are pushed back to H by the load balance, a cycle. A run
        whose best residual has not improved for ``_STALL_ITERATIONS`` returns ``_STALLED`` for the caller's
        fallback (:func:`_solve_by_offset`).

        On the GPU (``Backend.defer``) the iterations run in speculative groups (:meth:`_speculate`, module doc);
        the decisions, and so the iterations, the fields and the status, are the same as one by one.
        """
        status = self._iterate()
        self.h0, self.residual = float(self.h0), float(self.residual)
        return status

    def _iterate(self) -> int:
        best, best_at = math.inf, 0
        watch_stall = self.load is not None and math.isfinite(self.cap)
        eager = 0 if self.defer else -1  # iterations to run with host decisions before speculating again
        self.group, self.seen, self.carried = _CHECK_EVERY, [], None
        while True:
            if eager == 0:
                best, best_at, eager = self._speculate(best, best_at, watch_stall)
                if eager == 0:
                    continue
            m = self.measure()
            if m.residual <= self.tol:
                if self.exact:
                    return STATUS_CONVERGED
                self.finalise()
                continue
            if m.residual < 0.5 * best:
                best, best_at = m.residual, self.nit
            elif watch_stall and self.nit - best_at >= _STALL_ITERATIONS:
                return _STALLED
            if self.nit >= self.max_iter:
                self.finalise()
                self.measure()  # the residual (and h₀) of the state handed back
                return STATUS_MAX_ITERATIONS
            self.nit += 1
            eager -= eager > 0
            if not self.step(m):
                return STATUS_BREAKDOWN


def _solve_by_offset(solver: _Solver, load_total: float) -> int:
    """Load control with a cap by bracketing the separation h₀: the fallback when the load-controlled CG stalls.

    Under displacement control the capped problem is a well-posed convex one for every h₀, and the mean pressure
    p̄(h₀) is continuous and non-increasing: ny·nx·H for h₀ ≤ min z (every point penetrates, all at H) and 0 for
    h₀ ≥ max z. Brent's method on p̄(h₀) − p̄_target over that bracket, each evaluation a warm-started
    displacement-controlled solve (at 10⁻³·tol so that p̄(h₀) is smooth to the root), then the free pressures are
    rescaled to the exact load, which moves the contact conditions by about 10⁻³·tol. Iterations of every inner
    solve count against ``max_iter``.
    """
    budget, used = solver.max_iter, solver.nit
    outer_tol = solver.tol
    solver.load, solver.tol = None, max(1e-14, 1e-3 * outer_tol)
    status = STATUS_CONVERGED

    def excess(h0: float) -> float:
        nonlocal used, status
        solver.h0, solver.nit, solver.conjugate = h0, 0, False
        solver.max_iter = max(1, budget - used)
        warm = solver.p.copy()
        cold = solver.xp.clip((solver.z - h0) / solver.kernel.self_compliance, 0.0, solver.cap)
        solver.start(warm if float(warm.sum()) > 0.0 else cold)
        inner = solver.run()
        used += solver.nit
        status = max(status, inner)
        return float(solver.p.sum()) - load_total

    lo, hi = float(solver.z.min()), float(solver.z.max())
    try:
        h0 = optimize.brentq(excess, lo, hi, xtol=1e-14 * max(1.0, hi - lo), rtol=8 * np.finfo(float).eps)
        excess(h0)
    except ValueError:  # no sign change: an inner solve failed at an end of the bracket
        status = max(status, STATUS_BREAKDOWN)
    solver.load, solver.tol, solver.max_iter, solver.nit = load_total, outer_tol, budget, used
    if not solver._rescale():
        solver._plastic_reset()
    solver._recompute()
    load_h0 = solver.h0
    solver.load = None
    residual = solver.measure().residual
    solver.load, solver.h0 = load_total, load_h0
    if status == STATUS_CONVERGED and residual > outer_tol:
        status = STATUS_MAX_ITERATIONS if used >= budget else STATUS_BREAKDOWN
    return status


# ---------------------------------------------------------------------------------------------------------------
# Analysis of a solution.


def contact_spots(mask: ArrayLike, pixel_m: float = 1.0) -> tuple[int, _Array]:
    """Contact spots of a periodic boolean contact mask: (count, areas in m² largest first).

    Spots are 4-connected components (``scipy.ndimage.label``) merged across the periodic boundary, so a spot cut by
    the box edge counts once. Area = points × ``pixel_m``².
    """
    arr = np.asarray(mask, dtype=bool)
    if arr.ndim != 2:
        raise SettingError("mask", f"array of shape {arr.shape}", "expected a 2-D boolean array")
    pixel_m = check_range("pixel_m", pixel_m, 0.0, None, lo_open=True, unit="m")
    count, cells = _spot_cells(arr, np, ndimage.label)
    return count, cells * pixel_m**2


def _spot_cells(mask: Any, xp: ModuleType, label: Any) -> tuple[int, _Array]:
    """(count, points per spot, largest first) of a periodic 2-D boolean mask of namespace ``xp`` labelled by
    ``label`` (``scipy.ndimage.label`` or CuPy's): the components, merged across the box edges on the host."""
    labels, count = label(mask)
    count = int(count)
    if count == 0:
        return 0, np.empty(0)
    parent = np.arange(count + 1)

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = int(parent[i])
        return i

    edges = xp.concatenate(
        [xp.stack([labels[:, 0], labels[:, -1]], axis=1), xp.stack([labels[0, :], labels[-1, :]], axis=1)]
    )
    edges = np.asarray(edges if xp is np else xp.asnumpy(edges))  # 2(ny + nx) labels: the box edges only
    edges = edges[(edges[:, 0] > 0) & (edges[:, 1] > 0)]
    for a, b in np.unique(edges, axis=0):
        ra, rb = root(int(a)), root(int(b))
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    for i in np.unique(edges):  # only labels on the boundary can have been merged
        parent[i] = root(int(i))
    roots = parent if xp is np else xp.asarray(parent)
    sizes = xp.bincount(roots[labels.ravel()], minlength=count + 1)[1:]
    sizes = np.asarray(sizes if xp is np else xp.asnumpy(sizes))
    sizes = sizes[sizes > 0]
    return int(sizes.size), np.sort(sizes.astype(np.float64))[::-1]


def _label_function(xp: ModuleType) -> Any:
    """Connected-component labelling for arrays of ``xp``: ``scipy.ndimage.label``, or CuPy's on the GPU."""
    if xp is np:
        return ndimage.label
    try:
        from cupyx.scipy import ndimage as device_ndimage  # type: ignore[import-not-found, import-untyped, unused-ignore]
    except Exception:  # a namespace without its own (NumPy stand-ins in the tests): label on the host
        return lambda mask: ndimage.label(np.asarray(mask))
    return device_ndimage.label


def _perimeter_edges(mask: Any, xp: ModuleType = np) -> int:
    """Contact/non-contact 4-neighbour pairs, periodic (the M of Yastrebov et al. 2017)."""
    return int(xp.count_nonzero(mask != xp.roll(mask, 1, axis=0)) + xp.count_nonzero(mask != xp.roll(mask, 1, axis=1)))


@dataclass(frozen=True)
class _Scales:
    shape: tuple[int, int]  # (ny, nx)
    pixel_m: float
    E_star: float
    length: float  # ℓ, m
    pressure: float  # E* ℓ / Δ, Pa
    mean: float  # mean(z), m
    peak: float  # max(z) − mean(z), dimensionless


def _build_result(
    solver: _Solver, sc: _Scales, *, status: int, message: str, mode: str, hardness: float | None, p_full: float
) -> ContactResult:
    """The result in SI units; the fields and counts are made where the solver's arrays are (on the GPU, on the
    card) and only the finished fields (and the 2(ny + nx) boundary labels) are copied to the host."""
    shape = sc.shape
    xp = solver.xp
    to_host = solver.op.be.to_host
    p, w = solver.p, solver.w
    touching = p > 0.0
    contact = touching.reshape(shape)
    n_spots, spot_cells = _spot_cells(contact, xp, _label_function(xp))
    edges = _perimeter_edges(contact, xp)
    n_contact = int(xp.count_nonzero(touching))
    gap = w + solver.h0
    saturated = p >= solver.cap
    n_saturated = int(xp.count_nonzero(saturated))
    plastic = None
    if hardness is not None:
        plastic = to_host(xp.where(saturated, xp.maximum(-gap, 0.0), 0.0).reshape(shape) * sc.length)
        plastic.setflags(write=False)
    gap[touching] = 0.0
    xp.maximum(gap, 0.0, out=gap)
    size = shape[0] * shape[1]
    mean_pressure = float(p.sum()) / size * sc.pressure
    pressure = to_host((p * sc.pressure).reshape(shape))
    displacement = to_host(((w + solver.z) * sc.length).reshape(shape))
    gap_m = to_host((gap * sc.length).reshape(shape))
    for arr in (pressure, displacement, gap_m):
        arr.setflags(write=False)
    return ContactResult(
        mean_pressure=mean_pressure,
        mean_gap=float(gap_m.mean()),
        approach=(sc.peak - solver.h0) * sc.length,
        area_fraction=n_contact / size,
        area_fraction_corrected=max(0.0, (n_contact - YASTREBOV_FACTOR * edges) / size),
        perimeter_m=edges * sc.pixel_m,
        n_spots=n_spots,
        spot_areas=spot_cells * sc.pixel_m**2,
        plastic_fraction=n_saturated / size if hardness is not None else 0.0,
        full_contact_pressure=p_full * sc.pressure,
        nit=solver.nit,
        residual=solver.residual if math.isfinite(solver.residual) else 0.0,
        success=status == STATUS_CONVERGED,
        status=status,
        message=message,
        mode=mode,
        n=shape[1],
        shape=shape,
        pixel_m=sc.pixel_m,
        E_star=sc.E_star,
        hardness=hardness,
        workers=solver.workers,
        device=solver.op.be.name,
        pressure=pressure,
        gap=gap_m,
        displacement=displacement,
        plastic_depth=plastic,
    )


_MESSAGES = {
    STATUS_CONVERGED: "converged: residual {res:.2e} <= tol {tol:.2e} after {nit} iterations",
    STATUS_MAX_ITERATIONS: "iteration limit {nit} reached: residual {res:.2e} > tol {tol:.2e}",
    STATUS_BREAKDOWN: "numerical breakdown after {nit} iterations (residual {res:.2e}); a finite state is returned",
}


# ---------------------------------------------------------------------------------------------------------------
# Public solvers.


def _scales(arr: NDArray[np.float64], pixel_m: float, E_star: float, be: Backend | None = None) -> tuple[Any, _Scales]:
    """The dimensionless heights (flat, mean-free, in units of ℓ = rms) as an array of ``be`` (default NumPy), and
    the scales; on the GPU the heights are copied to the card first and scaled there."""
    shape = (int(arr.shape[0]), int(arr.shape[1]))
    xp = np if be is None else be.xp
    a = arr if be is None else be.asarray(arr)
    mean = float(a.mean())
    z = a.reshape(-1) - mean
    length = float(xp.sqrt(xp.mean(z * z)))
    if length <= 64.0 * np.finfo(np.float64).eps * float(xp.abs(a).max()):
        z.fill(0.0)  # flat to rounding: no roughness to resolve, any length unit will do
        length = pixel_m
    z /= length
    pressure = E_star * length / pixel_m
    return z, _Scales(shape, pixel_m, E_star, length, pressure, mean, float(z.max()))


def _full_contact_field(z: Any, op: _Operator) -> Any:
    """C⁻¹(z − mean z): the pressure beyond the mean needed to close every gap (dimensionless)."""
    return op.apply(z, op.stiffness)


def full_contact_pressure(z: ArrayLike, pixel_m: float, E_star: float, *, workers: int | None = None) -> float:
    """Elastic mean pressure (Pa) at and above which the contact is complete: −min[C⁻¹(z − mean z)].

    C⁻¹ has the Fourier symbol E*|q|/2 (module doc). For Westergaard's z = Δ cos(2πx/λ) this is p* = πE*Δ/λ.
    """
    arr = _check_surface(z)
    pixel_m = check_range("pixel_m", pixel_m, 0.0, None, lo_open=True, unit="m")
    E_star = check_range("E_star", E_star, 0.0, None, lo_open=True, unit="Pa")
    zn, sc = _scales(arr, pixel_m, E_star)
    field = _full_contact_field(zn, _Operator(sc.shape, get_backend("cpu", _check_workers(workers))))
    return max(0.0, -float(field.min())) * sc.pressure


def _target(
    sc: _Scales,
    hardness: float | None,
    mean_pressure: float | None,
    mean_gap: float | None,
    approach: float | None,
) -> tuple[str, float | None, float]:
    """(mode, dimensionless load per point or None, dimensionless offset h₀ − mean z)."""
    pairs = (("mean_pressure", mean_pressure), ("mean_gap", mean_gap), ("approach", approach))
    given = [k for k, v in pairs if v is not None]
    if len(given) != 1:
        raise SettingError(
            "target", ", ".join(given) or "none", "expected exactly one of mean_pressure, mean_gap, approach"
        )
    if mean_pressure is not None:
        hi = hardness if hardness is not None else None
        p = check_range("mean_pressure", mean_pressure, 0.0, hi, lo_open=True, hi_open=True, unit="Pa")
        return "pressure", p / sc.pressure, 0.0
    peak_m = sc.peak * sc.length
    if mean_gap is not None:
        lo = 0.0 if hardness is None else None
        gap = check_range("mean_gap", mean_gap, lo, None, lo_open=True, unit="m")
        return "gap", None, gap / sc.length
    hi_app = peak_m if hardness is None else None
    app = check_range("approach", approach, 0.0, hi_app, hi_open=peak_m > 0.0, unit="m")
    return "gap", None, (peak_m - app) / sc.length


def _check_initial(initial: ArrayLike | None, sc: _Scales) -> _Array | None:
    """A warm-start pressure field (Pa, the shape of z, finite, ≥ 0) as a flat dimensionless array, or None."""
    if initial is None:
        return None
    p0 = np.asarray(initial, dtype=np.float64)
    if p0.shape != sc.shape or not np.all(np.isfinite(p0)) or np.any(p0 < 0.0):
        raise SettingError(
            "initial_pressure", f"array of shape {p0.shape}", "expected finite pressures >= 0 in Pa, the shape of z"
        )
    return p0.reshape(-1) / sc.pressure


def _initial_pressure(
    solver: _Solver, sc: _Scales, load: float | None, initial: Any | None, field: Any | None = None
) -> Any:
    """Warm start if given and loaded; else under pressure control the full-contact field ``field`` cut down to the
    load (:func:`_cut_full_contact`; :func:`solve_contact` passes it up to p̄ = ``_CUT_BELOW``·H) or without it
    Polonsky & Keer's uniform p̄; under displacement control the pressure each penetrating point would carry alone,
    (z − h₀)/C₀₀, capped."""
    if load is not None:
        if initial is not None and float(initial.sum()) > 0.0:
            return initial
        if field is not None:
            return _cut_full_contact(solver.xp, field, load, solver.cap)
        return solver.xp.full(sc.shape[0] * sc.shape[1], load)  # Polonsky & Keer's uniform start
    return solver.xp.clip((solver.z - solver.h0) / solver.kernel.self_compliance, 0.0, solver.cap)


def _cut_full_contact(xp: ModuleType, field: Any, mean: float, cap: float) -> Any:
    """A cold start for the mean pressure ``mean``: min(max(f + λ, 0), H′), f = C⁻¹(z − mean z) the pressure beyond
    the mean that closes every gap (:func:`_full_contact_field`, already made for the full-contact test), λ such that
    the mean is ``mean`` to ``_CUT_RTOL`` (the solver's start then scales it to the load exactly). Dimensionless, a new
    flat array.

    With λ = p̄ this is the exact solution once contact is complete; below that it puts the load where complete
    contact would press hardest, and the support starts near the contact's size instead of the whole grid, whose
    early iterations are the costliest. H′ = (1 − 2·``_CUT_RTOL``)·H: no point starts at the hardness, even after
    the start's scaling (≤ ``_CUT_RTOL``): a point at H stays there until its gap opens.

    Measured on issue 28's benchmark surface (one thread; iterations, uniform start → this one): 1024² 34 → 32
    elastic, 34 → 30 capped at H = 12 p̄ (1.5 → 1.3 s, 1.5 → 1.4 s), 32 → 27 capped at p̄/10, 48 → 49 elastic at
    10 p̄ (46 % contact; the same time); 512² elastic, two surfaces, 29 → 25–26, and 26–27 → 20–21 at p̄/10; at
    p̄ = 0.58 H, four surfaces, 36–43 → 32–34. Near the hardness load control can
    stall (the load nearly all at H, h₀ set by a few free points; then :func:`_solve_by_offset`, ~550 iterations),
    from either start and on different surfaces: at p̄ = 0.83 H on seven surfaces the uniform start stalled on one,
    this one on one to three (with or without H′). So above ``_CUT_BELOW``·H the solver keeps the uniform start
    (:func:`_initial_pressure`), the behaviour there unchanged. Below it a crest far above the rest can still stall
    load control from this start on a small grid (64² with one 3–30σ crest, plastic: 7 of 300 surfaces against 1 of
    300 from the uniform start; none at 128² and 256², with or without a crest, where this start took 17 % and
    11 % fewer iterations): :func:`solve_contact` then starts once more from the uniform pressure (≈ 200 stalled
    iterations spent, counted), so that this start never fails where the uniform one converges.

    λ: Newton's method on the piecewise-linear sum Σ min(max(f + λ, 0), H′) (slope: the points strictly between the
    bounds), safeguarded by bisection inside [−max f, H′ − min f] (p̄ − min f without a cap), where the sum is below
    and above the load; a few steps, one pass each, and at most ~50 more where the load is below the resolution of
    f + λ (p̄ ≲ 1e-13·|λ|: then the closest sum, off by more than ``_CUT_RTOL``, which the start's scaling corrects)."""
    target = mean * field.size
    top = cap * (1.0 - 2.0 * _CUT_RTOL) if math.isfinite(cap) else math.inf
    if not mean < top:  # a load within 0.2 % of the hardness: every point near H, Polonsky & Keer's uniform p̄
        return xp.full(field.size, mean)
    lo = -_max(field, 0.0)
    hi = (top if math.isfinite(top) else mean) - _min(field, 0.0)
    lam = min(max(mean, lo), hi)  # the full-contact shift: the sum is ≥ the load there without a cap
    best = (math.inf, lam)  # (|excess|, λ) of the closest sum
    for _ in range(100):
        shifted = field + lam
        cut = xp.clip(shifted, 0.0, top)
        excess = float(cut.sum()) - target
        if abs(excess) <= _CUT_RTOL * target:
            return cut
        best = min(best, (abs(excess), lam))
        if excess > 0.0:
            hi = lam
        else:
            lo = lam
        if not lo < 0.5 * (lo + hi) < hi:  # λ at its float resolution: the load is below that of f + λ
            break
        slope = float(xp.count_nonzero((shifted > 0.0) & (shifted < top)))
        step = lam - excess / slope if slope > 0.0 else math.nan
        lam = step if lo < step < hi else 0.5 * (lo + hi)
    return xp.clip(field + best[1], 0.0, top)  # the closest sum (one more pass, only where none met _CUT_RTOL)


def solve_contact(
    z: ArrayLike,
    pixel_m: float,
    E_star: float,
    mean_pressure: float | None = None,
    *,
    mean_gap: float | None = None,
    approach: float | None = None,
    hardness: float | None = None,
    tol: float = 1e-6,
    max_iter: int = 2000,
    workers: int | None = None,
    initial_pressure: ArrayLike | None = None,
    precondition: bool = True,
    device: str | None = None,
    xp: ModuleType | None = None,
) -> ContactResult:
    """Periodic normal contact of the rough surface ``z`` on an elastic half-space (Polonsky & Keer 1999).

    Args:
        z: composite heights, m, ny×nx (rows × columns, both even), periodic, pointing towards the half-space.
        pixel_m: grid pitch Δ, m, the same along both axes (square pixels).
        E_star: composite modulus E*, Pa.
        mean_pressure: prescribed mean pressure p̄ = F/A₀, Pa (> 0, < hardness). Full contact (p̄ at or above
            :func:`full_contact_pressure`, elastic) is returned exactly.
        mean_gap: instead, the prescribed separation of the mean planes h₀ − mean z, m; for an elastic solid this is
            the mean gap ū (> 0; ≥ max z − mean z means no contact). With a hardness it may be any value, and the
            mean of the returned (plastically closed) gap field is then larger by the mean plastic depth.
        approach: instead, the rigid-body approach δ since first touch, m (≥ 0; < max z − mean z if elastic);
            equivalent to ``mean_gap = max z − mean z − δ``.
        hardness: H, Pa: local pressures are capped at H (elastic–perfectly-plastic layer); None for elastic.
        tol: convergence tolerance on the contact residual, in units of rms(z) (see module doc).
        max_iter: iteration limit (status 1 when reached; the last state is returned with ``success`` False).
        workers: FFT threads, default ``os.cpu_count()``.
        initial_pressure: warm start, Pa, the shape of ``z`` (scaled to ``mean_pressure``), e.g. a neighbouring load
            step.
        precondition: filter the search direction by the stiffness E*|q|/2 (Fourier preconditioner, Vollebregt
            2014): 2.4× fewer iterations at 1024², and a count that grows far slower with the grid, for one more
            FFT pair per iteration. False: the plain Polonsky–Keer directions (the solver before issue 28).
        device: ``"cpu"`` or ``"gpu"`` (CuPy; :mod:`sims.bem_backend`); default :func:`~sims.bem_backend.
            default_device`. On the GPU the memory is checked first (:func:`sims.budget.check_bem_gpu`).
        xp: run on the generic array-namespace path with this module (NumPy: the GPU's code on the CPU).

    Returns:
        :class:`ContactResult`. Pressures are finite and in [0, H]; the load is met to rounding.

    Raises:
        SettingError: for any invalid setting (the field, value and what is allowed are named).
    """
    arr = _check_surface(z)
    pixel_m = check_range("pixel_m", pixel_m, 0.0, None, lo_open=True, unit="m")
    E_star = check_range("E_star", E_star, 0.0, None, lo_open=True, unit="Pa")
    hardness = _check_hardness(hardness)
    tol = check_range("tol", tol, 1e-14, 0.1)
    max_iter = check_int("max_iter", max_iter, 1, 10**7)
    be = get_backend(device, _check_workers(workers), xp)
    if be.name == "gpu":
        from sims.budget import check_bem_gpu

        check_bem_gpu((int(arr.shape[0]), int(arr.shape[1])))
    zd, sc = _scales(arr, pixel_m, E_star, be)
    mode, load, offset = _target(sc, hardness, mean_pressure, mean_gap, approach)
    initial = _check_initial(initial_pressure, sc)
    cap = math.inf if hardness is None else hardness / sc.pressure
    op = _Operator(sc.shape, be)
    size = sc.shape[0] * sc.shape[1]
    solver = _Solver(
        zd,
        op,
        load=None if load is None else load * size,
        offset=offset,
        hardness=cap,
        tol=tol,
        max_iter=max_iter,
        precondition=bool(precondition),
    )
    field = _full_contact_field(zd, op)
    p_full = max(0.0, -float(field.min()))
    shortcut = _shortcut(solver, field, load, p_full)
    if shortcut is not None:
        return _build_result(
            solver, sc, status=STATUS_CONVERGED, message=shortcut, mode=mode, hardness=hardness, p_full=p_full
        )
    warm = None if initial is None else be.asarray(initial)
    # the cut start: a cold start (no warm field carrying a load) under pressure control, up to p̄ = _CUT_BELOW·H
    cut = load is not None and (warm is None or float(warm.sum()) <= 0.0) and load <= _CUT_BELOW * solver.cap
    solver.start(_initial_pressure(solver, sc, load, warm, field if cut else None))
    del field
    status = solver.run()
    note = ""
    if status == _STALLED and cut:
        # the cut start can stall load control where the uniform one does not (an outlier crest at the hardness on
        # a small grid, issue 28's review): once more from Polonsky & Keer's uniform p̄, the iterations counted
        solver.conjugate = False
        solver.start(_initial_pressure(solver, sc, load, None))
        status = solver.run()
        note = " (restarted from the uniform pressure: load control stalled from the full-contact start)"
    if status == _STALLED:
        assert solver.load is not None
        status = _solve_by_offset(solver, solver.load)
        note += " (load control stalled with the load near the hardness; solved by bracketing the separation)"
    finite = bool(solver.xp.isfinite(solver.p).all()) and bool(solver.xp.isfinite(solver.w).all())
    if not (finite and math.isfinite(solver.h0)):
        solver.start(_initial_pressure(solver, sc, load, None))  # never hand back NaN: the safe starting state
        status = STATUS_BREAKDOWN
    message = _MESSAGES[status].format(res=solver.residual, tol=tol, nit=solver.nit) + note
    return _build_result(solver, sc, status=status, message=message, mode=mode, hardness=hardness, p_full=p_full)


def _shortcut(solver: _Solver, field: Any, load: float | None, p_full: float) -> str | None:
    """Exact solutions without iterating: elastic full contact (pressure control) or no contact (gap control)."""
    if load is not None:
        if load < p_full or load + float(field.max()) > solver.cap:
            return None
        field += load
        solver.xp.maximum(field, 0.0, out=field)
        solver._set_support(solver.xp.flatnonzero(field > 0.0), field[field > 0.0])
        solver.p[:] = field
        solver.h0 = 0.0
        solver.w[:] = 0.0
        solver.residual = 0.0
        return "full contact (exact: p = p̄ + C⁻¹(z − mean z) >= 0)"
    if solver.h0 >= float(solver.z.max()):
        solver.w[:] = -solver.z
        solver.residual = 0.0
        return "no contact (the surfaces do not touch at this separation)"
    return None


@dataclass(frozen=True)
class _Options:
    hardness: float | None
    tol: float
    max_iter: int
    workers: int | None
    precondition: bool = True
    device: str | None = None

    def solve(self, z: ArrayLike, pixel_m: float, E_star: float, p: float, warm: ArrayLike | None) -> ContactResult:
        return solve_contact(
            z,
            pixel_m,
            E_star,
            p,
            hardness=self.hardness,
            tol=self.tol,
            max_iter=self.max_iter,
            workers=self.workers,
            initial_pressure=warm,
            precondition=self.precondition,
            device=self.device,
        )


def solve_load_path(
    z: ArrayLike,
    pixel_m: float,
    E_star: float,
    pressures: Sequence[float] | ArrayLike,
    hardness: float | None = None,
    *,
    stiffness: Literal["centred", "forward", "path", "tangent"] = "centred",
    step: float = 5e-3,
    tol: float = 1e-6,
    max_iter: int = 2000,
    workers: int | None = None,
    keep_fields: bool = True,
    device: str | None = None,
) -> LoadPathResult:
    """Mean pressures in increasing order, each solve warm-started from the previous pressure field.

    The interfacial stiffness K = −dp̄/dū (Pa/m) comes from finite differences of the mean gap ū along the load:

    * ``"centred"`` (default): two extra warm-started solves at p̄(1 ± step); K = −2 step p̄ / (ū₊ − ū₋), error
      O(step²).
    * ``"forward"``: one extra solve at p̄(1 + step); K = −step p̄ / (ū₊ − ū); first order (the secant is the
      derivative at p̄(1 + step/2)).
    * ``"path"``: no extra solves; the three-point (second-order, unequal spacing) derivative of ū(p̄) through the
      path points, one-sided at the ends (a secant if only two pressures). Needs at least two pressures.
    * ``"tangent"``: no extra solves; the exact derivative of the discrete problem at the converged state, one
      preconditioned *linear* CG on its free points (Barber 2003: the stiffness of a rigid flat punch of the current
      contact area; :mod:`sims.bem_stiffness`), stopped when K changes by less than ``tol``·K, about 10 iterations
      of 1.5 FFT pairs where the centred pair of solves takes ~30 of 2.4. Where no point is free (every contact
      point at the hardness) it takes the centred difference. The finite differences differ from it by the contact
      set's steps inside their window (points joining or leaving change K by ~1/(contact points) each: 1e-4 relative
      at step 1e-3 on the 512² benchmark surface) and agree with it to ~1e-9 once the step is below the next change.

    The step must resolve ū: its change, about step·p̄/K, should be well above tol·rms(z).

    Args:
        z, pixel_m, E_star, hardness, tol, max_iter, workers, device: as for :func:`solve_contact`.
        pressures: mean pressures, Pa, strictly increasing, each > 0 (and below the hardness).
        stiffness: the scheme above (finite differences or the tangent).
        step: relative pressure step of the ``"centred"``/``"forward"`` schemes (and of the tangent's centred
            fallback), in (0, 0.5].
        keep_fields: keep every ny×nx field (:class:`ContactResult`); else keep the scalars only.

    Returns:
        :class:`LoadPathResult`.
    """
    arr = _check_surface(z)
    pvals = _check_pressures(pressures)
    method = check_choice("stiffness", stiffness, ("centred", "forward", "path", "tangent"))
    step = check_range("step", step, 0.0, 0.5, lo_open=True)
    if method == "path" and pvals.size < 2:
        raise SettingError("pressures", pvals.tolist(), "expected at least two pressures for stiffness='path'")
    opts = _Options(hardness, tol, max_iter, _check_workers(workers), device=device)
    results: list[ContactSummary] = []
    gaps = np.empty(pvals.size)
    stiff = np.empty(pvals.size)
    nit = 0
    ok = True
    previous: _Array | None = None
    for i, p in enumerate(pvals):
        res = opts.solve(arr, pixel_m, E_star, float(p), previous)
        nit += res.nit
        ok = ok and res.success
        gaps[i] = res.mean_gap
        if method != "path":
            k, extra_nit, extra_ok = _local_stiffness(arr, pixel_m, E_star, res, float(p), method, step, opts)
            stiff[i] = k
            nit += extra_nit
            ok = ok and extra_ok
        previous = res.pressure
        results.append(res if keep_fields else res.summary())
    if method == "path":
        stiff = -1.0 / _path_derivative(pvals, gaps)
    return LoadPathResult(
        pressures=pvals,
        mean_gap=gaps,
        area_fraction=np.array([r.area_fraction for r in results]),
        stiffness=stiff,
        stiffness_method=method,
        results=tuple(results),
        nit=nit,
        success=ok,
    )


def _check_pressures(pressures: Sequence[float] | ArrayLike) -> _Array:
    try:
        pvals = np.asarray(pressures, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise SettingError("pressures", pressures, "expected a sequence of mean pressures in Pa") from None
    if pvals.size == 0:
        raise SettingError("pressures", [], "expected at least one mean pressure in Pa")
    for i, p in enumerate(pvals):
        check_range(f"pressures[{i}]", float(p), 0.0, None, lo_open=True, unit="Pa")
    if np.any(np.diff(pvals) <= 0.0):
        raise SettingError("pressures", pvals.tolist(), "expected strictly increasing mean pressures")
    return pvals


def _local_stiffness(
    arr: NDArray[np.float64],
    pixel_m: float,
    E_star: float,
    res: ContactResult,
    p: float,
    method: str,
    step: float,
    opts: _Options,
) -> tuple[float, int, bool]:
    """K = −dp̄/dū at p from warm-started solves at p(1 ± step) (centred) or p(1 + step) (forward), or from the
    linear solve on the state's free set (tangent, :func:`sims.bem_stiffness.tangent_stiffness`; centred where no
    point is free)."""
    if method == "tangent":
        from sims.bem_stiffness import tangent_stiffness

        t = tangent_stiffness(res, tol=opts.tol, max_iter=opts.max_iter, workers=opts.workers, device=opts.device)
        if t.stiffness is not None:
            return t.stiffness, t.nit, t.success
        method = "centred"
    upper = p * (1.0 + step)
    if opts.hardness is not None and upper >= opts.hardness:
        upper = p + 0.5 * (opts.hardness - p)
    plus = opts.solve(arr, pixel_m, E_star, upper, res.pressure)
    if method == "forward":
        lo_p, lo_gap, nit, ok = p, res.mean_gap, plus.nit, plus.success
    else:
        lower = p * (1.0 - step)
        minus = opts.solve(arr, pixel_m, E_star, lower, res.pressure)
        lo_p, lo_gap, nit, ok = lower, minus.mean_gap, plus.nit + minus.nit, plus.success and minus.success
    dgap = plus.mean_gap - lo_gap
    k = -(upper - lo_p) / dgap if dgap < 0.0 else math.inf
    return k, nit, ok


def _path_derivative(x: _Array, y: _Array) -> _Array:
    """dy/dx at the points x: three-point Lagrange derivative (unequal spacing), one-sided at the ends."""
    if x.size == 2:
        d = (y[1] - y[0]) / (x[1] - x[0])
        return np.array([d, d])
    return np.gradient(y, x, edge_order=2)


# ---------------------------------------------------------------------------------------------------------------
# Fourier refinement and the grid-convergence check.


def _pad_axis(spec: NDArray[np.complex128], axis: int, m: int, half: bool) -> NDArray[np.complex128]:
    """Zero-pad a spectrum along ``axis`` from n to m modes; the Nyquist mode n/2 is split between ±n/2."""
    n = spec.shape[axis] if not half else 2 * (spec.shape[axis] - 1)
    shape = list(spec.shape)
    shape[axis] = m // 2 + 1 if half else m
    out = np.zeros(shape, dtype=np.complex128)
    k = n // 2

    def sl(a: int, b: int) -> tuple[slice, ...]:
        s = [slice(None)] * spec.ndim
        s[axis] = slice(a, b)
        return tuple(s)

    out[sl(0, k)] = spec[sl(0, k)]
    out[sl(k, k + 1)] = 0.5 * spec[sl(k, k + 1)]
    if not half:
        out[sl(m - k, m - k + 1)] += 0.5 * spec[sl(k, k + 1)]
        out[sl(m - k + 1, m)] = spec[sl(k + 1, n)]
    return out


def refine(z: ArrayLike, factor: int) -> _Array:
    """Fourier interpolation of a periodic ny×nx surface onto factor·ny × factor·nx points (pixel / factor), m.

    The spectrum is zero-padded (the Nyquist mode split evenly between ±n/2 so the result stays real), so the refined
    surface passes exactly (to rounding) through the original samples, ``refine(z, f)[::f, ::f] == z``, and equals the
    continuous surface wherever that is band-limited below the original Nyquist wavenumber π/Δ.
    """
    arr = _check_surface(z)
    factor = check_int("factor", factor, 1, 64)
    my, mx = (k * factor for k in arr.shape)
    if max(my, mx) > _MAX_N:
        raise SettingError("factor", factor, f"expected factor·max(ny, nx) <= {_MAX_N}")
    if factor == 1:
        return arr.copy()
    spec = sfft.rfft2(arr)
    spec = _pad_axis(spec, 1, mx, half=True)
    spec = _pad_axis(spec, 0, my, half=False)
    return sfft.irfft2(spec, s=(my, mx)) * float(factor * factor)


def convergence_check(
    z: ArrayLike,
    pixel_m: float,
    E_star: float,
    mean_pressure: float,
    *,
    factor: int = 2,
    hardness: float | None = None,
    tol: float = 1e-6,
    max_iter: int = 2000,
    workers: int | None = None,
    device: str | None = None,
) -> ConvergenceCheck:
    """Solve at the grid of ``z`` and on ``refine(z, factor)`` and report the relative change of the real area.

    A small change (and a smaller one of the perimeter-corrected area) says the grid resolves the contact; the
    surface is assumed band-limited (Fourier interpolation is then exact), so only the contact discretisation
    changes.
    """
    factor = check_int("factor", factor, 2, 16)
    opts = _Options(hardness, tol, max_iter, workers, device=device)
    coarse = opts.solve(z, pixel_m, E_star, mean_pressure, None)
    fine = opts.solve(refine(z, factor), pixel_m / factor, E_star, mean_pressure, None)

    def rel(a: float, b: float) -> float:
        return (b - a) / b if b > 0.0 else (0.0 if a == b else math.inf)

    return ConvergenceCheck(
        coarse=coarse.summary(),
        fine=fine.summary(),
        factor=factor,
        relative_area_change=rel(coarse.area_fraction, fine.area_fraction),
        relative_corrected_area_change=rel(coarse.area_fraction_corrected, fine.area_fraction_corrected),
    )

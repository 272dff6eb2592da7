"""The tangent stiffness of a contact state: K = −dp̄/dū as one linear solve on the current contact set.

The seed paper tabulates the contact pressure against the separation of the surfaces, p(h) (its Fig. 2, the
database of §2.1); the interfacial stiffness is that curve's slope, K = −dp̄/dū (Pa/m, ū the mean gap), and through
Barber's relation it also gives the clean-metal contact resistance: r = (ρ₁ + ρ₂)·E*/(2K) per unit nominal area
(Ω·m², ρ the resistivities; Barber, Proc. R. Soc. A 459 (2003) 53).

Barber's theorem (same paper): the incremental normal stiffness of an elastic contact equals that of a rigid flat
punch of the current contact area — the points joining or leaving the contact carry no pressure to first order.
On the discrete problem of :mod:`sims.bem` this is exact: at a converged state, let F be the free points
(0 < p < H), P those at the hardness (p = H, which stay there: plastic flow) and the rest open (p = 0). An approach
dδ of the rigid surface (the separation h₀ falls by dδ) keeps g = 0 on F, so the pressure change x·dδ solves

    C_FF x = 1_F,     C the periodic compliance 2/(E*|q|) (m/Pa), zero at q = 0 as in :mod:`sims.bem`,

and dp̄/dδ = Σx/(ny·nx). While the sets do not change this is the derivative of the discrete problem itself: the
pressure and the gap are linear in h₀ between two changes of the set (which add or remove one point each). The
mean gap that :mod:`sims.bem` reports is the mean of the gap of the deformed surfaces, zero where p > 0, so that with
plastic points dū = −dδ·(1 − Σ_P(1 − (C x)_P)/(ny·nx)) (the plastic points flatten by the approach less their
elastic displacement); without them dū = −dδ. Then

    K = −dp̄/dū = [Σ x/(ny·nx)] / [1 − Σ_P (1 − (C x)_P)/(ny·nx)]      (Pa/m).

In the solver's dimensionless kernel 2/(|q|Δ) (Δ the pixel) the solution of kernel_FF·x̂ = 1_F gives
x = (E*/Δ)·x̂, so K = (E*/Δ)·mean(x̂)/(…) in Pa/m, independent of the height scale.

Solver: conjugate gradients on F with the solver's Fourier preconditioner — the residual on F filtered by the
stiffness |q|Δ/2 (the inverse of the compliance on the whole grid, float32 as in the contact solver) and restricted
to F again (Vollebregt, J. Comput. Phys. 257 (2014) 333) — with the Polak–Ribière β (robust to the float32 filter).
Each iteration is one float64 FFT pair (C d) and one float32 pair (the filter), through :class:`sims.bem._Operator`
on the solve's backend (NumPy, or CuPy on the GPU: one implementation). From x₀ = 0 the iterates' sum Σx_k rises
monotonically to Σx (Σx − Σx_k = ‖x − x_k‖²_C, the energy norm of the error, in exact arithmetic with a fixed
preconditioner; with the float32 filter measured monotonic to ~3e-10 relative), so the last iteration's change
estimates what is left. With plastic points the settling Σ_P (C x)_P is linear in the error, not quadratic, and
converges slower: the stop rule is a relative change below ``tol`` in one iteration of K itself, Σx_k/settle_k,
``tol`` being the contact solve's tolerance (1e-6 by default: on the 512² benchmark surface K is then within 4e-8 of
its converged value, after 9 iterations; with 60–65 % of the grid plastic, 128² and 256² test surfaces, within 4e-7
after 8–14, where a rule on Σx alone left 8e-6–1e-5), and ``max_iter`` caps the count (not converged: ``success``
False and the last estimate, never reported as converged).

Limits: full contact (no open point) has a mean gap of zero that stays zero, K = inf, as the finite differences
give (elastic, F every point: C_FF = C is singular on constants, no solution). With no free point (every contact
point at p = H) the state is a vertical step of ū(p̄) in the discrete problem (K = 0 at the fixed set) and the
stiffness is a chord over the next points to yield: ``stiffness`` is then None and :func:`sims.bem.solve_load_path`
takes the centred difference, as its centred scheme would.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from contactrig.core.validation import check_int, check_range
from sims.bem_backend import get_backend

if TYPE_CHECKING:
    from sims.bem import ContactResult

__all__ = ["TangentStiffness", "tangent_stiffness"]

#: a pressure within this relative distance of the hardness is at the hardness (the solver sets them to H exactly;
#: its result is scaled back to Pa, which may move it by a few units in the last place)
_AT_CAP = 1e-12


@dataclass(frozen=True)
class TangentStiffness:
    """K = −dp̄/dū of one contact state (:func:`tangent_stiffness`).

    Attributes:
        stiffness: K, Pa/m; inf at full contact; None where no point is free (every contact point at p = H).
        nit: conjugate-gradient iterations (one float64 and one float32 FFT pair each).
        success: converged (relative change of K below ``tol``), or an exact limit (full contact, no free point), and
            the contact state itself converged (``state.success``).
        message: what happened, in words.
    """

    stiffness: float | None
    nit: int
    success: bool
    message: str


def tangent_stiffness(
    state: ContactResult,
    *,
    tol: float = 1e-6,
    max_iter: int = 500,
    workers: int | None = None,
    device: str | None = None,
    xp: ModuleType | None = None,
) -> TangentStiffness:
    """K = −dp̄/dū (Pa/m) of a converged contact state from one linear solve on its free set (see module doc).

    Args:
        state: a :class:`sims.bem.ContactResult` (its pressure field, hardness, E*, pixel and shape are used).
        tol: stop when K changes by less than ``tol``·K in one iteration (the contact solve's ``tol``).
        max_iter: iteration limit (``success`` False when reached).
        workers, device, xp: where the arrays live, as for :func:`sims.bem.solve_contact`.
    """
    from sims import bem

    tol = check_range("tol", tol, 1e-14, 0.1)
    max_iter = check_int("max_iter", max_iter, 1, 10**6)
    be = get_backend(device, bem._check_workers(workers), xp)
    t = _tangent(state, tol, max_iter, be)
    if state.success:
        return t
    return replace(t, success=False, message=f"the contact state is not converged ({state.message}); {t.message}")


def _tangent(state: ContactResult, tol: float, max_iter: int, be: Any) -> TangentStiffness:
    """:func:`tangent_stiffness` with its settings checked, on the backend ``be``."""
    from sims import bem

    ns = be.xp
    p = np.asarray(state.pressure, dtype=np.float64).reshape(-1)
    cap = math.inf if state.hardness is None else state.hardness * (1.0 - _AT_CAP)
    free_host = np.flatnonzero((p > 0.0) & (p < cap))
    plastic_host = np.flatnonzero(p >= cap)
    size = p.size
    scale = state.E_star / state.pixel_m  # Pa/m per unit of the dimensionless x̂
    if free_host.size + plastic_host.size == size:
        return TangentStiffness(math.inf, 0, True, "full contact: the mean gap is zero and stays so (K = inf)")
    if free_host.size == 0:
        return TangentStiffness(None, 0, True, "no free point: every contact point is at the hardness")
    op = bem._Operator(state.shape, be)
    free = ns.asarray(free_host)
    plastic = ns.asarray(plastic_host)
    k_hat, u_plastic, nit, ok, why = _solve(op, free, plastic, tol, max_iter)
    settle = 1.0 - (plastic_host.size - float(u_plastic)) / size if plastic_host.size else 1.0
    if not settle > 0.0:  # the open points' gaps do not close on approach: none left to speak of
        return TangentStiffness(math.inf, nit, ok, f"the mean gap does not change (its rate {-settle:.1e}): K = inf")
    stiffness = scale * k_hat / size / settle
    if not ok:
        return TangentStiffness(stiffness, nit, False, why)
    return TangentStiffness(stiffness, nit, True, f"converged: K changed by < {tol:.1e}·K after {nit} iterations")


def _solve(op: Any, free: Any, plastic: Any, tol: float, max_iter: int) -> tuple[float, Any, int, bool, str]:
    """Preconditioned CG for kernel_FF x̂ = 1_F: (Σx̂, Σ_P (kernel x̂)_P, iterations, converged, why not); stopped on
    the relative change of K ∝ Σx̂/settle (one read on the host)."""
    from sims.bem import _dot

    xp = op.xp
    size = op.shape[0] * op.shape[1]
    grid = xp.zeros(size)
    grid32 = xp.zeros(size, dtype=xp.float32)

    def filtered(r: Any) -> Any:
        grid32[free] = r
        return op.apply(grid32, op.stiffness32)[free].astype(xp.float64)

    x = xp.zeros(free.size)
    r = xp.ones(free.size)
    s = filtered(r)
    d = s.copy()
    rs = _dot(xp, r, s)
    u_plastic = xp.zeros(())
    unsettled = float(size - plastic.size)  # N·settle = N − |P| + Σ_P (kernel x̂)_P, in points
    k_old = 0.0
    for it in range(1, max_iter + 1):
        grid[free] = d
        cd_grid = op.apply(grid, op.compliance)
        cd = cd_grid[free]
        curvature = _dot(xp, d, cd)
        if not (curvature > 0.0 and rs > 0.0 and math.isfinite(curvature)):
            return float(x.sum()), u_plastic, it, False, f"breakdown after {it} iterations (curvature {curvature:.2e})"
        alpha = rs / curvature
        x += alpha * d
        if plastic.size:
            u_plastic = u_plastic + alpha * cd_grid[plastic].sum()
        r_old = r.copy()
        r -= alpha * cd
        # the stop rule on K itself, the plastic points' settling included: that is a linear functional of the error
        # (not its energy norm as Σx̂), slower to converge (at 1e-6 on Σx̂ alone K was 1e-5 off with 60 % plastic)
        k = float(x.sum() / (unsettled + u_plastic)) if plastic.size else float(x.sum())
        if abs(k - k_old) <= tol * abs(k) and k > 0.0:
            return float(x.sum()), u_plastic, it, True, ""
        k_old = k
        s = filtered(r)
        rs_new = _dot(xp, r, s)
        beta = max(0.0, (rs_new - _dot(xp, r_old, s)) / rs)  # Polak–Ribière: robust to the float32 filter
        d *= beta
        d += s
        rs = rs_new
    return float(x.sum()), u_plastic, max_iter, False, f"not converged: K still changing after {max_iter} iterations"

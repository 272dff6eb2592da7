"""Issue 28: the BEM solver's Fourier preconditioner, its array namespace (NumPy or CuPy), ``--device`` and the GPU's
memory check.

References independent of the preconditioned solver: the plain Polonsky–Keer directions (``precondition=False``,
the solver before issue 28, computed here), a bound-constrained quadratic program solved by SciPy's L-BFGS-B with
the influence matrix built here in numpy (the elastic energy ½pᵀCp − pᵀ(z − h₀), p ≥ 0), and Johnson's Hertz
closed form (tests/sims/test_bem.py::test_hertz_sphere runs the default, preconditioned solver).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import optimize

from contactrig.core.budget import BudgetError
from contactrig.core.validation import SettingError
from sims import bem, bem_backend
from sims.budget import check_bem_gpu

from .test_bem import numpy_displacement, rough_surface

N, E_STAR = 128, 1.0
PIX = 1.0 / N


def _cupy_with_device() -> bool:
    try:
        bem_backend.get_backend("gpu")
    except SettingError:
        return False
    return True


HAVE_GPU = _cupy_with_device()


@pytest.fixture(scope="module")
def surface() -> np.ndarray:
    return rough_surface(N, seed=7)


@pytest.fixture(scope="module")
def large() -> np.ndarray:
    return rough_surface(256, seed=7)


@pytest.mark.parametrize(("hardness", "fewer"), [(None, 0.6), (0.03, 0.85)])
def test_preconditioned_fields_equal_the_plain_polonsky_keer_solution_in_fewer_iterations(large, hardness, fewer):
    # at plastic saturation the active-set changes, not the conditioning, set much of the count: a smaller gain
    p_mean = 0.025 * 0.1
    tol = 1e-10
    new = bem.solve_contact(large, 1 / 256, E_STAR, p_mean, hardness=hardness, tol=tol)
    old = bem.solve_contact(large, 1 / 256, E_STAR, p_mean, hardness=hardness, tol=tol, precondition=False)
    assert new.success and old.success
    scale = float(old.pressure.max())
    assert float(np.abs(new.pressure - old.pressure).max()) <= 1e-6 * scale
    assert new.area_fraction == old.area_fraction
    assert new.mean_gap == pytest.approx(old.mean_gap, rel=1e-7)
    if hardness is not None:
        assert new.plastic_fraction == old.plastic_fraction > 0
    assert new.nit <= fewer * old.nit  # the point of the preconditioner (31 against 71 elastic, 33 against 43)


def test_displacement_control_against_a_bound_constrained_quadratic_program():
    # 32² points: p minimises ½pᵀCp − pᵀ(z − h₀) over p ≥ 0 (C from the numpy FFT of the test module, built column by
    # column); L-BFGS-B on that energy is an independent solver of the same problem.
    n = 32
    z = rough_surface(n, seed=11, cut=2)
    z = (z - z.mean()) / z.std()
    pix, h0 = 1.0 / n, 1.0
    basis = np.eye(n * n).reshape(n * n, n, n)
    c = np.stack([numpy_displacement(b, pix, E_STAR).ravel() for b in basis])  # symmetric, zero-mean columns
    target = z.ravel() - h0

    def energy(p: np.ndarray) -> tuple[float, np.ndarray]:
        cp = c @ p
        return 0.5 * float(p @ cp) - float(p @ target), cp - target

    ref = optimize.minimize(energy, np.zeros(n * n), jac=True, method="L-BFGS-B", bounds=[(0, None)] * (n * n),
                            options={"ftol": 1e-15, "gtol": 1e-13, "maxiter": 20000})  # fmt: skip
    res = bem.solve_contact(z, pix, E_STAR, mean_gap=h0, tol=1e-10)
    assert res.success
    p_ref = ref.x.reshape(n, n)
    assert float(np.abs(res.pressure - p_ref).max()) <= 1e-5 * float(p_ref.max())


def test_namespace_path_on_the_cpu_gives_the_same_fields(surface):
    # numpy passed as xp: the generic path the GPU runs (xp.fft, no scipy.fft workers)
    fast = bem.solve_contact(surface, PIX, E_STAR, 0.0025, hardness=0.03, tol=1e-9)
    generic = bem.solve_contact(surface, PIX, E_STAR, 0.0025, hardness=0.03, tol=1e-9, xp=np)
    assert generic.device == fast.device == "cpu"
    assert generic.nit == fast.nit
    np.testing.assert_allclose(generic.pressure, fast.pressure, rtol=0, atol=1e-9 * float(fast.pressure.max()))


def test_default_device_is_cpu_and_the_context_sets_it():
    assert bem_backend.default_device() == "cpu"
    with bem_backend.use_device("cpu"):
        assert bem_backend.default_device() == "cpu"
    with pytest.raises(SettingError, match="--device"):
        with bem_backend.use_device("tpu"):
            pass


@pytest.mark.skipif(HAVE_GPU, reason="CuPy and a CUDA device are present: the refusal cannot be shown")
def test_gpu_without_cupy_or_card_is_refused_in_one_line(surface):
    with pytest.raises(SettingError, match=r"pip install 'contactrig\[gpu\]'|no CUDA device") as info:
        bem.solve_contact(surface, PIX, E_STAR, 0.0025, device="gpu")
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    "command", [["compare-models", "--pressures", "1MPa"], ["database", "-o", "x.h5"], ["simulate"]]
)
@pytest.mark.skipif(HAVE_GPU, reason="CuPy and a CUDA device are present: the refusal cannot be shown")
def test_device_gpu_option_is_refused_before_any_work(command, tmp_path, monkeypatch, capsys):
    from contactrig.cli.main import main

    monkeypatch.chdir(tmp_path)
    assert main([*command, "--device", "gpu"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--device" in err and "gpu" in err
    assert not (tmp_path / "x.h5").exists()


def test_scene_key_device_is_validated_and_read(tmp_path):
    from contactrig.core.scene import default_scene_text, parse_scene

    text = default_scene_text()
    scene = parse_scene(text.replace("[scene]", '[scene]\ndevice = "gpu"', 1), "s.toml")
    assert bem_backend.scene_device(None, scene) == "gpu"
    assert bem_backend.scene_device("cpu", scene) == "cpu"  # the option wins
    assert bem_backend.scene_device(None, parse_scene(text, "d.toml")) == "cpu"
    with pytest.raises(SettingError, match=r"\[scene\] device"):
        parse_scene(text.replace("[scene]", '[scene]\ndevice = "tpu"', 1), "s.toml")


def test_gpu_memory_is_estimated_and_refused_before_start():
    # 224 B per point (at most 220 measured on an H200, 1024²–8192²): 8192² needs 14 GiB; 4 GiB free is refused
    est = check_bem_gpu(8192, free_bytes=16 * 2**30)
    assert est.peak_bytes == pytest.approx(224 * 8192**2)
    with pytest.raises(BudgetError, match=r"8192×8192.*GPU"):
        check_bem_gpu(8192, free_bytes=4 * 2**30)


@pytest.mark.skipif(not HAVE_GPU, reason="needs CuPy and a CUDA device (pip install 'contactrig[gpu]')")
def test_gpu_fields_equal_the_cpu_fields(surface):
    cpu = bem.solve_contact(surface, PIX, E_STAR, 0.0025, hardness=0.03, tol=1e-9)
    gpu = bem.solve_contact(surface, PIX, E_STAR, 0.0025, hardness=0.03, tol=1e-9, device="gpu")
    assert gpu.device == "gpu" and gpu.success
    assert float(np.abs(gpu.pressure - cpu.pressure).max()) <= 1e-6 * float(cpu.pressure.max())
    assert math.isclose(gpu.area_fraction, cpu.area_fraction, abs_tol=2 / N**2)


def test_database_with_bem_on_a_small_gpu_is_refused_before_any_surface(monkeypatch):
    # the GPU's free memory (1 MiB) cannot hold the default scene's 512² solve: refused by the database's own check
    from contactrig.core.scene import load_scene
    from sims import budget
    from sims.config import SimConfig
    from sims.database import build_database

    config = SimConfig.from_scene(load_scene(None))
    monkeypatch.setattr(bem_backend, "gpu_memory_bytes", lambda: 2**20)
    monkeypatch.setattr(bem_backend, "_DEVICE", bem_backend.ContextVar("device", default="gpu"))
    monkeypatch.setattr(budget, "database", lambda *a, **k: budget.Estimate("database", "keys", 0.0))
    with pytest.raises(BudgetError, match=r"\[surfaces\.liner\].*GPU"):
        build_database(config, ["bem"])

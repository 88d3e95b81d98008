"""demcal.Scene: a scene file or dict built (what it holds, its time step) and simulated, with the
particles' end state as numpy arrays."""

from __future__ import annotations

import math
try:
    import tomllib  # Python 3.11+
except ModuleNotFoundError:  # 3.9 and 3.10: the test extra installs tomli
    import tomli as tomllib

import numpy as np
import pytest

import demcal

G = 9.81
RHO = 2500.0
R = 0.002


def free_fall(steps: int = 1000) -> dict:
    """64 spheres 6 mm apart (never touching), thrown sideways at 0.1 m/s, falling freely."""
    return {
        "simulation": {"steps": steps, "time_step": 1e-5, "gravity": [0.0, 0.0, -G],
                       "domain": {"min": [-0.1, -0.1, -1.0], "max": [0.2, 0.1, 0.2]}},
        "material": [{"name": "glass", "density": RHO, "poisson_ratio": 0.3, "youngs_modulus": 1e7}],
        "interaction": [{"materials": ["glass", "glass"], "restitution": 0.5, "static_friction": 0.5,
                         "rolling_friction": 0.05}],
        "particles": [{"material": "glass", "size": {"type": "fixed", "radius": R},
                       "region": {"type": "box", "min": [0, 0, 0], "max": [0.02, 0.02, 0.02]},
                       "fill": {"type": "lattice", "lattice": "sc", "spacing": 0.006},
                       "velocity": [0.1, 0.0, 0.0]}],
    }


@pytest.fixture(scope="module")
def box(box_scene_file):
    return demcal.Scene.load(box_scene_file)


def test_load_builds_the_scene(box, box_scene_file):
    assert box.name == str(box_scene_file) and box.folder == str(box_scene_file.parent)
    # 9 x 9 lattice sites across 0.036 m at 4.5 mm, 11 up 0.048 m.
    assert box.particles == 9 * 9 * 11
    assert box.geometries == 1
    assert box.steps == 2000
    assert box.contact_model == "hertz_mindlin"
    # time_step_percent = 20: a fifth of the Rayleigh step.
    assert box.time_step_s == pytest.approx(0.2 * box.rayleigh_time_step_s, rel=1e-12)
    # The Rayleigh step of glass spheres, r = 2 mm: pi r sqrt(rho / G) / (0.1631 nu + 0.8766).
    shear = 1e7 / (2 * 1.3)
    rayleigh = math.pi * R * math.sqrt(RHO / shear) / (0.1631 * 0.3 + 0.8766)
    assert box.rayleigh_time_step_s == pytest.approx(rayleigh, rel=1e-3)
    assert box.warnings == [] and box.notes == []
    with open(box_scene_file, "rb") as f:
        assert box.to_dict() == tomllib.load(f)


def test_simulate_gives_the_end_state_as_arrays(box):
    end = box.simulate(steps=500, threads=2)
    n = box.particles
    assert end.particles == n
    for a in (end.position, end.velocity):
        assert isinstance(a, np.ndarray) and a.dtype == np.float64 and a.shape == (n, 3)
    assert end.radius.shape == (n,) and np.all(end.radius == R)
    assert end.steps == 500
    assert end.simulated_s == pytest.approx(500 * box.time_step_s, rel=1e-12)
    assert end.bonds is None
    assert end.wall_s > 0 and end.particle_steps_per_s == pytest.approx(n * 500 / end.wall_s, rel=1e-9)
    # Every sphere is still in the open box (the walls at 0 and 0.04 m, the floor at 0).
    assert np.all(end.position[:, :2] > R * 0.99) and np.all(end.position[:, :2] < 0.04 - R * 0.99)
    assert np.all(end.position[:, 2] > R * 0.99) and np.all(end.position[:, 2] < 0.05)
    # The kinetic energy counts the translation (and the rotation, never negative).
    mass = RHO * 4 / 3 * math.pi * R**3
    translational = 0.5 * mass * float(np.sum(end.velocity**2))
    assert end.kinetic_energy_j >= translational * (1 - 1e-12)
    assert end.kinetic_energy_j < translational * 1.5 + 1e-12


def test_the_file_run_length_and_determinism(box):
    a = box.simulate(threads=2)  # the file's 2000 steps
    assert a.steps == box.steps == 2000
    # The same run again, and on one thread: identical (forces are summed in a fixed order).
    b = box.simulate(threads=1)
    np.testing.assert_array_equal(a.position, b.position)
    np.testing.assert_array_equal(a.velocity, b.velocity)
    assert a.kinetic_energy_j == b.kinetic_energy_j
    # The lattice has 0.5 mm gaps: after 2000 steps (0.069 s) the layers have dropped onto each
    # other and the bed is near rest.
    assert a.kinetic_energy_j < 1e-4
    assert a.position[:, 2].max() < 0.05


def test_free_fall_follows_the_exact_kinematics():
    s = demcal.Scene.from_dict(free_fall())
    assert s.particles == 64 and s.geometries == 0 and s.time_step_s == 1e-5 and s.steps == 1000
    start = s.simulate(steps=0)
    assert start.steps == 0 and start.simulated_s == 0.0
    end = s.simulate(threads=1)
    t = end.simulated_s
    assert t == pytest.approx(0.01, rel=1e-12)
    np.testing.assert_allclose(end.velocity, np.tile([0.1, 0.0, -G * t], (64, 1)), rtol=1e-10, atol=1e-14)
    moved = end.position - start.position
    np.testing.assert_allclose(moved, np.tile([0.1 * t, 0.0, -0.5 * G * t * t], (64, 1)), rtol=1e-6, atol=1e-12)
    mass = RHO * 4 / 3 * math.pi * R**3
    assert start.kinetic_energy_j == pytest.approx(64 * 0.5 * mass * 0.1**2, rel=1e-12)
    assert end.kinetic_energy_j == pytest.approx(64 * 0.5 * mass * (0.1**2 + (G * t) ** 2), rel=1e-10)


def test_a_particle_leaving_the_domain_stops_the_run():
    d = free_fall(steps=2000)
    d["simulation"]["domain"] = {"min": [-0.01, -0.01, -0.001], "max": [0.05, 0.05, 0.05]}
    with pytest.raises(demcal.RunError, match=r"particle \d+ left the simulation domain at t = ") as e:
        demcal.Scene.from_dict(d, name="leaky").simulate()
    assert str(e.value).startswith("leaky: ")


def test_a_particle_leaving_the_domain_raises_escaped_error():
    d = free_fall(steps=2000)
    d["simulation"]["domain"] = {"min": [-0.01, -0.01, -0.001], "max": [0.05, 0.05, 0.05]}
    with pytest.raises(demcal.EscapedError):
        demcal.Scene.from_dict(d).simulate()


def test_to_dict_is_a_copy():
    d = free_fall()
    s = demcal.Scene.from_dict(d)
    d["simulation"]["steps"] = 5
    assert s.to_dict()["simulation"]["steps"] == 1000
    changed = s.to_dict()
    changed["simulation"]["steps"] = 7
    assert s.steps == 1000 and demcal.Scene.from_dict(changed).steps == 7


def test_bad_scenes_are_input_errors(tmp_path):
    with pytest.raises(demcal.InputError, match="cannot read: No such file"):
        demcal.Scene.load(tmp_path / "missing.toml")
    d = free_fall()
    d["simulation"]["time_stepp"] = 1e-5
    with pytest.raises(demcal.InputError, match=r"^mine: .*time_stepp"):
        demcal.Scene.from_dict(d, name="mine")
    d = free_fall()
    d["particles"][0]["material"] = "steel"
    with pytest.raises(demcal.InputError, match=r"steel"):
        demcal.Scene.from_dict(d)
    with pytest.raises(demcal.InputError, match=r"^steps=20000000000: at most"):
        demcal.Scene.from_dict(free_fall()).simulate(steps=20_000_000_000)
    with pytest.raises(demcal.InputError, match=r"threads=0"):
        demcal.Scene.from_dict(free_fall()).simulate(steps=1, threads=0)

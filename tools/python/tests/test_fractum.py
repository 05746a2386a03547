"""The Python package against the engine and the command line: runs bitwise equal to
`fractum run`, errors with their place, the GIL released while a run steps, Ctrl-C leaving a
checkpoint that resumes bitwise, arrays of the right shapes, scenes that pickle, and bad input
as exceptions, never a crash.

`.ci/run` runs these in a virtual environment under target/ against the extension built by
cargo; FRACTUM_BIN names the `fractum` binary to compare with (target/debug/fractum there)."""

import math
import os
import pickle
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import fractum

REPO = Path(__file__).resolve().parents[3]
SCENES = REPO / "scenes"


def fractum_bin():
    named = os.environ.get("FRACTUM_BIN")
    if named:
        return named
    built = REPO / "target" / "debug" / "fractum"
    if not built.exists():
        pytest.skip("no fractum binary: build it (cargo build) or set FRACTUM_BIN")
    return str(built)


def longer_impact(end_time=3.0e-2 * 3):
    """cracked_bar_impact.ron run three times as long: a few seconds of stepping."""
    scene = fractum.Scene.load(SCENES / "cracked_bar_impact.ron")
    scene.end_time = end_time
    return scene


# -- runs --------------------------------------------------------------------------------


def test_a_python_run_writes_the_series_of_the_command_line_bit_for_bit(tmp_path):
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    subprocess.run(
        [fractum_bin(), "run", str(SCENES / "cracked_bar_impact.ron"), "--out", str(cli_out),
         "--threads", "2", "--quiet"],
        check=True, capture_output=True,
    )
    run = fractum.run(SCENES / "cracked_bar_impact.ron", out=py_out, threads=2, progress=False)
    assert (py_out / "series.csv").read_bytes() == (cli_out / "series.csv").read_bytes()
    assert run.summary["exit"] == "end"
    assert run.summary["steps"] == int(run.series["step"][-1])
    assert len(run.frames) == len(fractum.open(cli_out).frames) > 2
    # The scene it ran sits beside the outputs.
    assert run.scene.text == (SCENES / "cracked_bar_impact.ron").read_text()


def test_a_run_reports_progress_and_its_summary(tmp_path):
    calls = []
    run = fractum.run(SCENES / "two_disks.ron", out=tmp_path / "r", threads=1,
                      progress=lambda step, t, fraction: calls.append((step, t, fraction)))
    assert calls and calls[-1][2] == pytest.approx(1.0)
    assert all(a[0] <= b[0] for a, b in zip(calls, calls[1:]))
    summary = run.summary
    assert summary["particles"] == 416 and summary["threads"] == 1
    assert summary["particle_steps_per_s"] > 0 and summary["wall_s"] > 0
    series = run.series
    assert series["step"].dtype == np.int64 and series["time"].dtype == np.float64
    assert set(series) >= {"kinetic_energy", "total_energy", "com_velocity_x"}


def test_a_folder_that_holds_a_run_is_refused_unless_forced(tmp_path):
    fractum.run(SCENES / "tension_rankine.ron", out=tmp_path / "r", progress=False, steps=10)
    with pytest.raises(OSError, match="holds a previous run"):
        fractum.run(SCENES / "tension_rankine.ron", out=tmp_path / "r", progress=False, steps=10)
    again = fractum.run(SCENES / "tension_rankine.ron", out=tmp_path / "r", progress=False,
                        steps=10, force=True)
    assert again.summary["exit"] == "steps"


def test_a_run_releases_the_gil_while_it_steps(tmp_path):
    scene = longer_impact()
    finished = threading.Event()
    wall = {}

    def in_background():
        started = time.monotonic()
        fractum.run(scene, out=tmp_path / "r", threads=1, progress=False)
        wall["run"] = time.monotonic() - started
        finished.set()

    worker = threading.Thread(target=in_background)
    worker.start()
    beats = [time.monotonic()]
    while not finished.is_set():
        sum(range(2000))  # pure Python: needs the GIL
        beats.append(time.monotonic())
    worker.join()
    gaps = np.diff(beats)
    # Held for the run, the GIL would stop this thread for the whole run (seconds).
    assert wall["run"] > 1.0, wall
    assert len(beats) > 100
    assert gaps.max() < 0.5 * wall["run"], (gaps.max(), wall["run"])


def test_ctrl_c_leaves_a_checkpoint_that_resumes_bit_for_bit(tmp_path):
    scene = longer_impact()
    scene_file = tmp_path / "impact.ron"
    scene.save(scene_file)
    reference = fractum.run(scene_file, out=tmp_path / "whole", threads=2, progress=False)
    # Python handles SIGINT only where it was not ignored when it started; a shell's background
    # job (as CI may run this in) starts with it ignored, so the child installs the handler a
    # terminal's Python has.
    script = textwrap.dedent(f"""
        import signal, sys, fractum
        signal.signal(signal.SIGINT, signal.default_int_handler)
        def said(step, t, fraction):
            if step > 0:
                print("running", flush=True)
        try:
            fractum.run({str(scene_file)!r}, out={str(tmp_path / 'cut')!r}, threads=2,
                        progress=said)
        except KeyboardInterrupt as e:
            print("interrupted:", e, flush=True)
            sys.exit(130)
    """)
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "running"
    child.send_signal(signal.SIGINT)
    said, _ = child.communicate(timeout=120)
    assert child.returncode == 130, said
    assert "fractum.resume(" in said
    cut = fractum.open(tmp_path / "cut")
    assert cut.checkpoints, said
    assert cut.summary["steps"] < reference.summary["steps"]
    resumed = fractum.resume(tmp_path / "cut", threads=2, progress=False)
    assert resumed.summary["exit"] == "end"
    whole = (tmp_path / "whole" / "series.csv").read_bytes()
    assert (tmp_path / "cut" / "series.csv").read_bytes() == whole


def test_ctrl_c_while_the_progress_callback_runs_is_the_same_interrupt(tmp_path):
    # A Ctrl-C that lands while the callback's Python code runs raises `KeyboardInterrupt` in
    # the callback: the run still finishes its step, writes a checkpoint and says how to resume.
    scene_file = tmp_path / "impact.ron"
    longer_impact().save(scene_file)

    def pressed(step, t, fraction):
        if step > 0:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt, match=r"fractum\.resume\("):
        fractum.run(scene_file, out=tmp_path / "cut", threads=2, progress=pressed)
    assert fractum.open(tmp_path / "cut").checkpoints


# -- stepping in memory ------------------------------------------------------------------


@pytest.mark.parametrize("name,dimension", [("two_disks", 2), ("bar_vibration_3d", 3)])
def test_particle_and_node_arrays_have_the_shapes_of_the_dimension(name, dimension):
    sim = fractum.Simulation(SCENES / f"{name}.ron", threads=1)
    assert sim.step(5) == 5 and sim.steps == 5 and sim.time > 0
    particles = sim.particles
    n = particles["position"].shape[0]
    assert n > 0
    assert particles["position"].shape == (n, dimension)
    assert particles["velocity"].shape == (n, dimension)
    assert particles["stress"].shape == (n, 3, 3)
    for column in ("mass", "volume", "damage", "strain_energy_density"):
        assert particles[column].shape == (n,) and particles[column].dtype == np.float64
    assert particles["id"].dtype == np.uint32 and particles["body"].dtype == np.uint16
    with pytest.raises(ValueError):
        particles["position"][0, 0] = 1.0  # a read-only snapshot
    nodes = sim.nodes
    m = nodes["index"].shape[0]
    slots = nodes["mass"].shape[1]
    assert m > 0 and nodes["velocity"].shape == (m, slots, dimension)
    assert nodes["position"].shape == (m, dimension)


def test_setting_initial_velocities_moves_the_body_and_the_energy_account():
    sim = fractum.Simulation(SCENES / "two_disks.ron", threads=1)
    n = sim.particles["position"].shape[0]
    before = sim.energy()["kinetic_energy"]
    velocity = np.zeros((n, 2))
    velocity[:, 0] = 1.0
    sim.particles["velocity"] = velocity
    masses = sim.particles["mass"]
    assert sim.energy()["kinetic_energy"] == pytest.approx(0.5 * masses.sum())
    assert sim.energy()["kinetic_energy"] != before
    sim.step(10)
    assert sim.series()["energy_residual"] == pytest.approx(0.0, abs=1e-6 * masses.sum())
    with pytest.raises(RuntimeError, match="only before the first step"):
        sim.particles["velocity"] = velocity
    fresh = fractum.Simulation(SCENES / "two_disks.ron", threads=1)
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        fresh.particles["velocity"] = np.zeros((n, 3))
    with pytest.raises(ValueError, match="one value per particle"):
        fresh.particles["damage"] = np.zeros(n + 1)
    with pytest.raises(KeyError, match="cannot be set"):
        fresh.particles["mass"] = np.ones(n)


def test_strength_scales_scale_the_laws_strengths_and_meet_their_checks():
    scene = fractum.Scene.load(SCENES / "cracked_bar_impact.ron")
    scene.system("damage/rankine").params["tensile_strength"] = 2.0e3
    halved = scene.copy()
    halved.system("damage/rankine").params["tensile_strength"] = 1.0e3
    sim = fractum.Simulation(scene, threads=1)
    strength = sim.particles["strength"]
    n = strength.shape[0]
    varied = np.linspace(0.5, 1.5, n)
    sim.particles["strength_scale"] = varied
    assert np.array_equal(sim.particles["strength"], strength * varied)
    # A second scale replaces the first: a uniform half is the scene with half the strength,
    # step for step, past the impact's first damage (about step 300).
    sim.particles["strength_scale"] = np.full(n, 0.5)
    reference = fractum.Simulation(halved, threads=1)
    assert np.array_equal(sim.particles["strength"], reference.particles["strength"])
    seeded = np.count_nonzero(reference.particles["damage"])
    assert sim.step(320) == reference.step(320) == 320
    assert np.count_nonzero(reference.particles["damage"]) > seeded
    assert np.array_equal(sim.particles["damage"], reference.particles["damage"])
    fresh = fractum.Simulation(scene, threads=1)
    # 1000 × 2 kPa leaves the Rankine law no softening branch on the scene's cell diagonal.
    with pytest.raises(ValueError, match="damage/rankine refuses it: .*snap back"):
        fresh.particles["strength_scale"] = np.full(n, 1.0e3)
    assert np.array_equal(fresh.particles["strength"], strength)
    with pytest.raises(ValueError, match="finite and positive"):
        fresh.particles["strength_scale"] = np.zeros(n)
    with pytest.raises(ValueError, match="one value per particle"):
        fresh.particles["strength_scale"] = np.ones(n - 1)
    unbreakable = fractum.Simulation(SCENES / "two_disks.ron", threads=1)
    with pytest.raises(ValueError, match="no damage law"):
        unbreakable.particles["strength_scale"] = np.ones(unbreakable.particles["id"].shape[0])


def test_a_blowup_raises_with_its_step_and_stage():
    sim = fractum.Simulation(SCENES / "two_disks.ron", threads=1)
    n = sim.particles["position"].shape[0]
    # 1 km/s with the scene's fixed 1 ms step: a metre a step, out of the 1 m grid.
    sim.particles["velocity"] = np.tile([1.0e3, 0.0], (n, 1))
    with pytest.raises(fractum.RunError, match="left the grid") as raised:
        sim.step(1000)
    assert raised.value.step == 1 and raised.value.stage == "advection"
    assert "particle 0" in str(raised.value)


# -- scenes ------------------------------------------------------------------------------


def test_edits_keep_the_text_and_read_back():
    scene = fractum.Scene.load(SCENES / "charpy_dfg.ron")
    rankine = scene.system("damage/rankine").params
    rankine["tensile_strength"] = 6e8
    scene.materials["bar"].youngs_modulus = 2.1e11
    scene.grid.spacing = 0.5e-3
    scene.end_time = 1e-5
    scene.output.grid_every = 50  # absent from the file: added
    assert rankine["tensile_strength"] == 6e8
    assert scene.materials["bar"]["youngs_modulus"] == 2.1e11
    assert scene["grid.spacing"] == 0.5e-3 and scene.end_time == 1e-5
    assert scene.output.grid_every == 50 and scene.output.vtu_every == 200
    assert rankine["degradation"] == "Spectral"
    assert rankine["critical_opening"] if "critical_opening" in rankine else True
    # Comments survive; the scene was edited.
    assert "// A simplified Charpy test" in scene.text and scene.edited
    check = scene.check()
    assert check["particles"] > 0 and check["end_time"] == 1e-5
    assert check["pipeline"]["damage"] == ["damage/rankine"]
    assert str(check).endswith("ok\n")


def test_a_scene_pickles_with_its_edits():
    scene = fractum.Scene.load(SCENES / "tension_rankine.ron")
    scene.system("damage/rankine").params["tensile_strength"] = 1.5e6
    again = pickle.loads(pickle.dumps(scene))
    assert again == scene and again.text == scene.text and again.edited
    assert again.record_path() == scene.record_path()
    assert again.system("damage/rankine").params["tensile_strength"] == 1.5e6


def test_errors_carry_the_file_line_column_and_field(tmp_path):
    text = (SCENES / "two_disks.ron").read_text()
    bad = text.replace("poisson_ratio: 0.3", "poisson_ratio: 0.7", 1)
    assert bad != text
    path = tmp_path / "bad.ron"
    path.write_text(bad)
    scene = fractum.Scene.load(path)
    with pytest.raises(fractum.SceneError) as raised:
        scene.check()
    error = raised.value
    assert error.file == str(path) and error.field.endswith("poisson_ratio")
    line = bad[: bad.index("poisson_ratio: 0.7")].count("\n") + 1
    assert error.line == line and error.col > 1
    assert f"{path}:{line}:" in str(error)
    cli = subprocess.run([fractum_bin(), "check", str(path)], capture_output=True, text=True)
    assert cli.returncode == 1 and error.message in cli.stderr


def test_bad_input_raises_clear_exceptions():
    with pytest.raises(FileNotFoundError, match="cannot read the scene file"):
        fractum.Scene.load("no/such/scene.ron")
    with pytest.raises(fractum.SceneError, match="<scene from Python>:1:"):
        fractum.Scene.from_str("(time: ")
    scene = fractum.Scene.load(SCENES / "tension_rankine.ron")
    with pytest.raises(KeyError, match="did you mean 'damage/rankine'"):
        scene.system("damage/rankin")
    params = scene.system("damage/rankine").params
    with pytest.raises(TypeError, match="holds a number"):
        params["tensile_strength"] = "high"
    with pytest.raises(KeyError, match="did you mean 'tensile_strength'"):
        params["tensile_strenght"] = 1e6
    with pytest.raises(KeyError, match="no material"):
        scene.materials["steal"]
    with pytest.raises(fractum.SceneError):
        scene["grid.spacing"] = fractum.Ron("(1.0")
    with pytest.raises(ValueError, match="finite"):
        scene.grid.spacing = float("nan")
    with pytest.raises(FileNotFoundError, match="holds no run"):
        fractum.open("no/such/run")
    with pytest.raises(OSError, match="no checkpoint"):
        fractum.resume(REPO / "scenes", progress=False)
    # A wrong value the engine refuses raises where the engine finds it, with its place.
    scene.grid.spacing = -1.0
    with pytest.raises(fractum.SceneError, match="grid.spacing"):
        scene.check()


# -- analysis ----------------------------------------------------------------------------


def test_the_analysis_tools_return_data(tmp_path):
    run = fractum.run(SCENES / "cracked_bar_impact.ron", out=tmp_path / "r", threads=2,
                      progress=False)
    peak = fractum.curve(run, "time", "strain_energy")
    assert peak["peak"] == np.abs(run.series["strain_energy"]).max()
    frame = run.frame(-1)
    assert frame["dimension"] == 2 and frame["time"] == run.frames[-1][0]
    assert frame["damage"].max() > 0.5
    png = fractum.snapshot(run, field="damage")
    assert Path(png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    pieces = fractum.fragments(run)
    assert pieces["mass"].shape == pieces["diameter"].shape and pieces["centroid"].shape[1] == 3
    names = {s["name"]: s for s in fractum.systems()}
    assert "tensile_strength" in {p["name"] for p in names["damage/rankine"]["params"]}


def test_the_guides_sweep_runs_on_two_processes(tmp_path):
    pytest.importorskip("matplotlib")
    figure = tmp_path / "sweep.png"
    said = subprocess.run(
        [sys.executable, str(REPO / "docs" / "guide" / "python_sweep.py"), "--out",
         str(tmp_path / "runs"), "--figure", str(figure)],
        check=True, capture_output=True, text=True,
    ).stdout
    dissipated = [float(line.split("dissipated ")[1].split(" mJ")[0])
                  for line in said.splitlines() if line.startswith("σ_f")]
    # A stronger bar damages less: the dissipated energy falls along the sweep.
    assert len(dissipated) == 5 and all(a > b for a, b in zip(dissipated, dissipated[1:]))
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_readmes_python_example_runs(tmp_path):
    readme = (REPO / "README.md").read_text()
    example = readme.split("```python\n", 1)[1].split("```", 1)[0]
    # From the repository's root, as the README says, with the outputs kept out of it.
    (tmp_path / "scenes").symlink_to(SCENES)
    said = subprocess.run([sys.executable, "-c", example], cwd=tmp_path, check=True,
                          capture_output=True, text=True).stdout
    steps, dissipated = said.split(" steps, ")
    assert int(steps) > 0 and float(dissipated.split(" J")[0]) > 0
    assert (tmp_path / "out" / "cracked_bar" / "series.csv").exists()


def test_check_gives_the_runs_length_and_names_unit_slips():
    scene = fractum.Scene.load(SCENES / "charpy_dfg.ron")
    check = scene.check()
    assert check["steps"] == math.ceil(check["end_time"] / check["time_step"])
    assert check["warnings"] == []
    assert check["step_seconds"] > 0 and check["wall_estimate_s"] > 0
    assert f"run        {int(check['steps'])} steps" in str(check)
    striker = scene.copy()
    striker.materials["striker"].youngs_modulus = 190.0  # GPa meant
    check = striker.check()
    assert len(check["warnings"]) == 1, check["warnings"]
    assert check["warnings"][0].startswith("`materials.striker.youngs_modulus`: 190 Pa")
    assert "GPa meant? 190 GPa is 1.9e11 Pa" in check["warnings"][0]
    assert "warning    `materials.striker.youngs_modulus`" in str(check)
    # The bar's softening law refuses the slip; the slip is named beside the refusal.
    scene.materials["bar"].youngs_modulus = 190.0
    with pytest.raises(fractum.SceneError, match="snap back") as refused:
        scene.check()
    assert refused.value.notes[0].startswith("note: `materials.bar.youngs_modulus`")
    assert "GPa meant?" in str(refused.value)

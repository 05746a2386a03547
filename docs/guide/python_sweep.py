"""A parameter study from Python: the Rankine tensile strength of scenes/cracked_bar_impact.ron
swept over five values on two processes, the energy each run dissipates plotted against it,
and the damage of the weakest bar drawn with matplotlib.

    python docs/guide/python_sweep.py --out out/sweep --figure out/sweep/sweep.png

The guide (docs/guide/python.md) shows the figure this writes; tools/python/tests runs it."""

import argparse
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import fractum

SCENE = Path(__file__).resolve().parents[2] / "scenes" / "cracked_bar_impact.ron"
STRENGTHS = [500.0, 1000.0, 2000.0, 3000.0, 4000.0]  # Pa


def run_one(scene, out):
    """One run of the sweep (a worker process): the scene arrives pickled, edits and all."""
    run = fractum.run(scene, out=out, threads=1, progress=False, force=True)
    return run.out, run.series["dissipated_energy"][-1], run.series["total_energy"][0]


def sweep(out):
    """Runs the five scenes on two processes; (strength, run folder, dissipated, initial
    energy) of each."""
    base = fractum.Scene.load(SCENE)
    scenes, folders = [], []
    for strength in STRENGTHS:
        scene = base.copy()
        scene.system("damage/rankine").params["tensile_strength"] = strength
        scenes.append(scene)
        folders.append(Path(out) / f"strength_{strength:g}")
    with ProcessPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(run_one, scenes, folders))
    return [(s, *r) for s, r in zip(STRENGTHS, results)]


def plot(results, figure):
    """Dissipated energy against strength, and the damage of the weakest bar at its end."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    strengths = [r[0] for r in results]
    dissipated = [r[2] * 1e3 for r in results]
    fig, (left, right) = plt.subplots(2, 1, figsize=(8, 6.4), height_ratios=[1.5, 1])
    left.plot(strengths, dissipated, marker="o")
    left.set_xlabel("tensile strength σ_f (Pa)")
    left.set_ylabel("dissipated energy (mJ)")
    left.set_title("energy the damage dissipates (2D, the scene's 1 m thickness)")
    left.grid(True, alpha=0.3)
    weakest = fractum.open(results[0][1]).frame(-1)
    x, y = weakest["position"][:, 0] * 1e3, weakest["position"][:, 1] * 1e3
    dots = right.scatter(x, y, c=weakest["damage"], s=9, cmap="viridis", vmin=0.0, vmax=1.0)
    right.set_aspect("equal")
    right.set_xlabel("x (mm)")
    right.set_ylabel("y (mm)")
    right.set_title(f"damage at t = {weakest['time'] * 1e3:.1f} ms, σ_f = {strengths[0]:g} Pa")
    fig.colorbar(dots, ax=right, label="damage", orientation="horizontal", pad=0.3, shrink=0.6)
    fig.tight_layout()
    Path(figure).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(figure, dpi=110)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/sweep", help="folder of the runs")
    parser.add_argument("--figure", default="out/sweep/sweep.png", help="the PNG to write")
    args = parser.parse_args()
    results = sweep(args.out)
    for strength, folder, dissipated, initial in results:
        print(f"σ_f = {strength:6g} Pa: dissipated {dissipated * 1e3:.3f} mJ "
              f"({100 * dissipated / initial:.1f}% of the impact's energy), {folder}")
    plot(results, args.figure)
    print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()

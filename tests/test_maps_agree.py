"""The maps of one sweep tell one story (issue 28, items 2 and 4).

* every map of one sweep has the same bounds, the same pixel size and the same count of
  poses ok at its payload (the capacity map, which is not of one payload, counts the poses
  with a capacity);
* the uncertainty map's title counts the fitted parameters as the fit does, and its log
  colour bars are labelled at round numbers that do not overlap;
* ``sweep --cycle`` names where the arm comes back worst, and by how much: the largest
  |(return_dx, return_dy)| of the Dataset; a model without memory gets a note, not an empty
  return map.
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.text import Text

import eodarm
from eodarm.cli import main
from eodarm.viz import maps as draw
from eodarm.viz.cycle_map import return_map
from eodarm.viz.uncertainty_maps import sag_uncertainty_map

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
E = eodarm.Effect
GRID = {
    "alpha1": np.linspace(40.0, 140.0, 11),
    "alpha2": np.linspace(-40.0, 60.0, 9),
    "alpha3": np.linspace(-30.0, 30.0, 5),
}
HIDDEN = [
    E("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
    E("joint_friction", "O2", torque_nmm=3000.0),
]
NOTE = re.compile(r"([\d,]+) of ([\d,]+) poses (ok at [\d.]+ kg|with a capacity); each ([\d.]+) mm")


@pytest.fixture(scope="module")
def fitted() -> eodarm.Arm:
    """The example arm fitted to a load cycle with a soft mount and a joint friction: two
    parameters in its [fit] table."""
    from eodarm.analysis.fit import fit
    from eodarm.analysis.handover import fitted_arm
    from eodarm.analysis.synth import random_configs, synth

    arm = eodarm.Arm.from_toml(EXAMPLE)
    alpha = random_configs(arm, 8, np.random.default_rng(3))
    meas = synth(arm, alpha, [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0], HIDDEN, seed=3, sequence=True)
    res = fit(arm, meas, ["mount_compliance@M2", "joint_friction@O2"])
    return fitted_arm(res, data="cycle.csv")


@pytest.fixture(scope="module")
def ds(fitted: eodarm.Arm) -> xr.Dataset:
    return eodarm.sweep(fitted, alpha_deg=GRID, mass_kg=[1.5, 6.5], uncertainty=True, cycle=True)


def _texts(fig: Figure) -> list[str]:
    return [t.get_text() for t in fig.findobj(Text)]


def _note(fig: Figure) -> tuple[int, int, str, float]:
    """(ok, total, what, pixel mm) of a map's note."""
    [m] = [m for t in _texts(fig) if (m := NOTE.search(t.replace("\n", " ")))]
    return int(m[1].replace(",", "")), int(m[2].replace(",", "")), m[3], float(m[4])


def test_the_maps_of_one_sweep_agree_on_poses_and_pixels(
    fitted: eodarm.Arm, ds: xr.Dataset
) -> None:
    figs = {
        "sag": draw.sag_map(ds, 6.5),
        "forces": draw.force_maps(ds, 6.5),
        "uncertainty": sag_uncertainty_map(ds, 6.5),
        "return": return_map(ds, 6.5),
        "dominant": draw.dominant_effect_map(fitted, {"alpha_deg": GRID}, [], 6.5, progress=False),
        "capacity": draw.capacity_map(fitted, {"alpha_deg": GRID}),
    }
    notes = {k: _note(f) for k, f in figs.items()}
    sel = ds.sel(mass_kg=6.5)
    ok = int((sel["ok"] & sel["reachable"]).sum())
    total = int(ds["reachable"].size)
    for name, (good, every, what, _) in notes.items():
        assert every == total, name
        if name != "capacity":
            assert (good, what) == (ok, "ok at 6.5 kg"), name  # the sweep's own count
    assert notes["capacity"][2] == "with a capacity"
    assert len({px for *_, px in notes.values()}) == 1, notes  # one pixel size for all
    # one frame: the same x and y limits on every map's first axes
    frames = {k: (f.axes[0].get_xlim(), f.axes[0].get_ylim()) for k, f in figs.items()}
    assert len(set(frames.values())) == 1, frames


def test_the_uncertainty_map_counts_the_fitted_parameters(ds: xr.Dataset) -> None:
    fig = sag_uncertainty_map(ds, 6.5)
    title = fig.get_suptitle()
    assert "covariance of 2 parameters" in title
    assert "1 fitted parameters" not in title


def test_log_colour_bars_are_labelled_at_round_numbers_that_do_not_overlap(
    ds: xr.Dataset,
) -> None:
    fig = sag_uncertainty_map(ds, 6.5)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert len(bars) == 2
    for bar in bars:
        labels = [t for t in bar.get_xticklabels() if t.get_text() and t.get_visible()]
        assert len(labels) >= 2
        boxes = sorted((t.get_window_extent(renderer) for t in labels), key=lambda b: b.x0)
        for a, b in itertools.pairwise(boxes):
            assert a.x1 < b.x0, [t.get_text() for t in labels]  # no two labels overlap
        for t in labels:  # numbers, not powers of ten
            assert "×" not in t.get_text() and "^" not in t.get_text()


def test_a_model_without_memory_gets_a_note_not_an_empty_return_map() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    elastic = [E("mount_compliance", "M2", stiffness_n_per_mm=4000.0)]
    ds = eodarm.sweep(arm, alpha_deg=GRID, mass_kg=[6.5], effects=elastic, cycle=True)
    fig = return_map(ds)
    said = " ".join(" ".join(_texts(fig)).split())
    assert "comes back to its reference in every ok cell" in said
    assert "nothing in this model (no friction, no gap) holds it off" in said
    assert not [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]  # no scale of zeros


def test_sweep_cycle_names_where_the_arm_comes_back_worst(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "cycle.nc"
    argv = ["sweep", "--arm", str(EXAMPLE), "--alpha1", "60:120:7", "--alpha2", "-20:30:6"]
    argv += ["--alpha3", "0", "--mass", "1.5,6.5", "--add", "joint_friction@O2=3000"]
    argv += ["--add", "mount_compliance@M2=4000", "--cycle", "-o", str(out), "--no-progress"]
    assert main(argv) == 0
    said = " ".join(capsys.readouterr().out.split())
    m = re.search(
        r"return to 0 kg: worst at alpha \(([^)]*)\) deg, load point \(([^)]*)\) mm after "
        r"([\d.]+) kg: ([\d.]+) mm off its reference",
        said,
    )
    assert m, said
    with xr.open_dataset(out) as ds:
        dist = np.hypot(ds["return_dx_mm"], ds["return_dy_mm"])
        worst = dist.where(dist == dist.max(), drop=True)
        assert float(m[4]) == pytest.approx(float(dist.max()), rel=5e-3)  # 3 digits
        assert float(m[3]) == float(worst["mass_kg"][0])
        angles = [float(a.replace("−", "-")) for a in m[1].split(", ")]
        assert angles == pytest.approx([float(worst[f"alpha{k}"][0]) for k in (1, 2, 3)], abs=1e-9)
    # an elastic model: the arm comes back exactly, and the summary says so
    argv = [a for a in argv if a != "joint_friction@O2=3000"]
    argv.remove("--add")
    argv[argv.index(str(out))] = str(tmp_path / "elastic.nc")
    assert main(argv) == 0
    said = " ".join(capsys.readouterr().out.split())
    assert "return to 0 kg: the arm comes back exactly in every ok cell" in said


def test_a_maps_notes_stay_inside_it_clear_of_its_ticks_and_of_each_other(
    fitted: eodarm.Arm,
) -> None:
    """The note under a map ("75,113 of 119,187 poses ok …; each 11.8 mm pixel shows …")
    ran in one line across the y tick labels (the capacity map's narrow left panel, the sag
    map of a wide grid); the range above it was placed at a fixed height, over it once it
    took two lines. Each now stays inside its map, and the range stands on top of it."""
    wide = {  # the grid of docs/sweeps.md's example maps, coarser
        "alpha1": np.linspace(20.0, 160.0, 15),
        "alpha2": np.linspace(-60.0, 90.0, 11),
        "alpha3": np.linspace(-60.0, 60.0, 7),
    }
    swept = eodarm.sweep(fitted, alpha_deg=wide, mass_kg=[6.5], cycle=True)
    figs = {
        "sag": draw.sag_map(swept, 6.5),
        "return": return_map(swept, 6.5),
        "capacity": draw.capacity_map(fitted, {"alpha_deg": wide}),
    }
    for name, fig in figs.items():
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
        ax = fig.axes[0]
        frame = ax.get_window_extent(renderer)
        texts = [t for t in ax.texts if t.get_text()]
        [note] = [t for t in texts if NOTE.search(t.get_text().replace("\n", " "))]
        box = note.get_window_extent(renderer)
        assert frame.x0 <= box.x0 and box.x1 <= frame.x1, name  # inside the map
        assert frame.y0 <= box.y0 and box.y1 <= frame.y1, name
        ticks = [t.get_window_extent(renderer) for t in ax.get_yticklabels() if t.get_text()]
        assert all(tick.x1 < box.x0 for tick in ticks), name
        above = [t for t in texts if t is not note and " from " in t.get_text()]
        for t in above:  # the range over the note: above it, never on it
            assert t.get_window_extent(renderer).y0 >= box.y1, name
        assert name == "capacity" or above, name  # the sag and return maps say their range

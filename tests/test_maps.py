"""Workspace maps (eodarm.maps): sag, forces, payload capacity, the dominant effect.

Promises tested here: the payload capacity is the payload at which the first actuator limit
(force, either sign, or stroke) is reached, checked against ``eodarm.solve`` just below and
just above it, and the binding limit is the one crossed; the dominant effect's numbers are
the report's sag budget of the same model (the arm file's effects included); a map shows
only reachable, solved poses and each pixel the worst pose that lands in it; one panel per
actuator; nothing is written without a path.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from matplotlib.collections import QuadMesh
from matplotlib.figure import Figure

import eodarm
from arms import example_arm
from eodarm.analysis.budget import sag_budget
from eodarm.errors import EodarmError
from eodarm.viz import maps as draw
from eodarm.workspace import maps

E = eodarm.Effect
GRID = {
    "alpha1": np.linspace(30.0, 150.0, 9),
    "alpha2": np.linspace(-50.0, 80.0, 7),
    "alpha3": np.linspace(-45.0, 45.0, 5),
}
MODEL = [
    E("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
    E("actuator_play", "M3", play_mm=0.4),
    E("joint_clearance", "O3", clearance_mm=0.15),
]


@pytest.fixture(scope="module")
def arm() -> eodarm.Arm:
    return example_arm()  # stroke and force limits set


@pytest.fixture(scope="module")
def ds(arm: eodarm.Arm) -> xr.Dataset:
    return eodarm.sweep(arm, alpha_deg=GRID, mass_kg=[1.5, 6.5], effects=MODEL)


def poses() -> np.ndarray:
    return np.stack(np.meshgrid(*GRID.values(), indexing="ij"), axis=-1).reshape(-1, 3)


#: Soft actuator bodies, so that some poses reach a stroke limit before a force limit.
SOFT = [E("actuator_compliance", f"M{i}", stiffness_n_per_mm=30.0) for i in (1, 2, 3)]


def limits_crossed(arm: eodarm.Arm, alpha: np.ndarray, mass: float) -> list[int] | None:
    """Codes of the limits beyond which the pose is at this payload (None: no solution)."""
    try:
        out = eodarm.solve(arm, alpha, mass, effects=[*SOFT, *MODEL], strict=True)
    except ValueError:
        return None
    crossed = []
    length = out["length_mm"][0] + out["dlength_mm"][0]
    for i, a in enumerate(arm.actuators):
        if abs(out["force_n"][0, i]) > a.max_force_n * (1 + 1e-9):
            crossed.append(i)
        if length[i] < a.min_length_mm - 1e-9 or length[i] > a.max_length_mm + 1e-9:
            crossed.append(arm.n + i)
    return crossed


def test_capacity_is_the_payload_where_the_first_limit_is_reached(arm: eodarm.Arm) -> None:
    # Force limits of 1500 N (not the example's 4000 N) bind away from the near-singular poses,
    # whose capacity is NaN (the model is not valid there, docs/model.md §7).
    d = arm.to_dict()
    for a in d["actuator"]:
        a["max_force_n"] = 1500.0
    arm = eodarm.Arm.from_dict(d)
    cap = maps.payload_capacity(arm, GRID, effects=[*SOFT, *MODEL], max_payload_kg=300.0)
    c = cap["capacity_kg"].values.ravel()
    lim = cap["limit"].values.ravel()
    reach = cap["reachable"].values.ravel()
    assert np.isnan(c[~reach]).all() and (lim[~reach] == -1).all()
    alpha = poses()
    checked = {"force": 0, "stroke": 0}
    for p in np.flatnonzero(reach & (c < 300.0) & (c > 0.0)):
        below = limits_crossed(arm, alpha[p], c[p] * (1 - 1e-7))
        above = limits_crossed(arm, alpha[p], c[p] * (1 + 1e-7) + 1e-9)
        if below is None or above is None:
            continue  # the loaded pose does not close there (near a singular pose)
        assert below == [], (p, c[p], below)
        assert lim[p] in above, (p, c[p], lim[p], above)
        checked["force" if lim[p] < arm.n else "stroke"] += 1
    assert checked["force"] > 10 and checked["stroke"] > 3, checked


def test_capacity_is_zero_where_self_weight_alone_is_too_much(arm: eodarm.Arm) -> None:
    weak = maps.assume_max_force(
        eodarm.Arm.from_dict(
            {
                **arm.to_dict(),
                "actuator": [
                    {k: v for k, v in a.items() if k != "max_force_n"}
                    for a in arm.to_dict()["actuator"]
                ],
            }
        ),
        1.0,
    )
    cap = maps.payload_capacity(weak, GRID)
    c = cap["capacity_kg"].values
    assert (c[np.isfinite(c)] == 0.0).all() and np.isfinite(c).any()


def test_capacity_is_capped(arm: eodarm.Arm) -> None:
    strong = maps.assume_max_force(arm.replace(name="strong"), 1.0)  # keeps the arm's limits
    assert strong.actuators == arm.actuators
    cap = maps.payload_capacity(arm, GRID, max_payload_kg=0.5)
    c = cap["capacity_kg"].values
    assert np.nanmax(c) == 0.5
    labels = str(cap.attrs["limit_labels"]).split(", ")
    assert labels[-1] == "cap" and (cap["limit"].values[c == 0.5] == len(labels) - 1).all()


#: A fitted model as ``fit -o`` writes it: stiff bodies and soft mounts, in the arm file.
FITTED = [
    E("actuator_compliance", "M1", stiffness_n_per_mm=13000.0),
    E("actuator_compliance", "M2", stiffness_n_per_mm=73000.0),
    E("mount_compliance", "M1", stiffness_n_per_mm=1500.0),
    E("mount_compliance", "M2", stiffness_n_per_mm=580.0),
    E("mount_compliance", "M3", stiffness_n_per_mm=920.0),
]


def test_the_dominant_effect_map_splits_the_sag_as_the_budget_does(arm: eodarm.Arm) -> None:
    """The map of an arm file that carries its fitted effects and the report's sag budget of
    the same model give every component the same share at a pose, and the shares add up to
    the model's own sag (eodarm.solve of the file)."""
    fitted = arm.with_effects(FITTED)
    g = {"alpha1": [70.0, 100.0], "alpha2": [0.0, 30.0], "alpha3": [-10.0, 10.0]}
    con = maps.effect_contributions(fitted, g, [], 6.5)
    alpha = np.stack(np.meshgrid(*g.values(), indexing="ij"), axis=-1).reshape(-1, 3)
    budget = sag_budget(fitted, alpha, 6.5)
    assert [str(v) for v in con["effect"].values] == budget.labels
    assert budget.labels[3:] == [e.key for e in FITTED[2:]]  # the file's mounts are in
    got = con["contribution_mm"].values.reshape(-1, len(budget.labels))
    total = eodarm.solve(fitted, alpha, 6.5)["dy_mm"]
    # sweep and solve run the same kernel: equal to rounding (1e-9 mm of a 10 mm sag)
    np.testing.assert_allclose(got, (budget.shares * np.sign(total)).T, atol=1e-9)
    np.testing.assert_allclose(got.sum(axis=1), np.abs(total), rtol=1e-9)
    # on this arm the mounts make most of the sag, as in the report; not the springs
    assert (np.isin(con["dominant"].values, [3, 4, 5])).all()


def test_an_arm_files_effects_count_as_the_same_effects_given_by_add(arm: eodarm.Arm) -> None:
    g = {"alpha1": [90.0], "alpha2": [10.0], "alpha3": [0.0]}
    in_file = maps.effect_contributions(arm.with_effects(FITTED), g, [], 6.5)
    added = maps.effect_contributions(arm, g, FITTED, 6.5)
    np.testing.assert_allclose(
        in_file["contribution_mm"].values, added["contribution_mm"].values, rtol=1e-12
    )
    assert in_file.attrs["model"] == added.attrs["model"]
    assert "mount_compliance@M2=580" in in_file.attrs["model"]


def test_the_budget_of_an_arm_file_with_effects_is_the_budget_of_its_model(
    arm: eodarm.Arm,
) -> None:
    """The file's effects are components of the budget, not part of a rigid arm."""
    alpha = [[90.0, 10.0, 0.0], [70.0, 20.0, -5.0]]
    in_file = sag_budget(arm.with_effects(FITTED), alpha, 5.0)
    added = sag_budget(arm, alpha, 5.0, FITTED)
    np.testing.assert_allclose(in_file.rigid, 0.0, atol=1e-9)  # a rigid arm does not sag
    np.testing.assert_allclose(in_file.shares, added.shares, rtol=1e-12, atol=1e-12)


def _mesh(fig: Figure, k: int = 0) -> np.ma.MaskedArray:
    meshes = [
        c
        for ax in fig.axes
        for c in ax.collections
        if isinstance(c, QuadMesh) and c.get_gid() != "not_ok"  # not the grey layer
    ]
    return np.ma.masked_invalid(np.ma.filled(meshes[k].get_array(), np.nan))


def test_the_sag_map_shows_only_reachable_solved_poses(ds: xr.Dataset) -> None:
    sel = ds.sel(mass_kg=6.5)
    good = (sel["reachable"] & sel["ok"]).values
    assert (~good).any() and good.any()
    poisoned = ds.copy(deep=True)
    poisoned["dy_mm"].values[~np.broadcast_to(good[..., None], ds["dy_mm"].shape)] = -1e6
    img = _mesh(draw.sag_map(poisoned, 6.5))
    shown = img.compressed()
    dy = sel["dy_mm"].values[good]
    if (dy < 0).all():  # every sound pose sags: the map shows the sag −dy (log scale)
        shown = -shown
    assert shown.min() > -1e6
    assert set(np.round(shown, 9)) <= set(np.round(dy, 9))
    # every pixel shows the most sagging pose that lands in it: the overall worst is there
    assert shown.min() == pytest.approx(float(dy.min()))


def test_a_pixel_shows_its_worst_pose(arm: eodarm.Arm) -> None:
    x = np.array([0.0, 0.1, 0.2, 50.0])
    y = np.array([0.0, 0.1, 0.2, 50.0])
    cv = draw._Canvas(arm, x, y, None)
    value = np.array([1.0, 5.0, 3.0, 7.0])
    _, _, img = cv.raster(x, y, value, worst=value)
    assert sorted(img.compressed().tolist()) == [5.0, 7.0]
    _, _, img = cv.raster(x, y, value, worst=-value)
    assert sorted(img.compressed().tolist()) == [1.0, 7.0]


def test_force_maps_have_one_panel_per_actuator_with_its_limit(ds: xr.Dataset) -> None:
    fig = draw.force_maps(ds, 6.5)
    panels = [ax for ax in fig.axes if ax.get_title().startswith("actuator")]
    assert [ax.get_title().split(":")[0] for ax in panels] == [
        "actuator 1",
        "actuator 2",
        "actuator 3",
    ]
    assert "limit ±4000 N" in panels[0].get_title()
    sel = ds.sel(mass_kg=6.5)
    good = (sel["reachable"] & sel["ok"]).values
    f2 = sel["force_n"].sel(actuator=2).values[good]
    img = _mesh(fig, 1).compressed()
    assert img.max() == pytest.approx(f2[np.argmax(np.abs(f2))]) or img.min() == pytest.approx(
        f2[np.argmax(np.abs(f2))]
    )


def test_capacity_and_dominant_maps_name_what_they_show(arm: eodarm.Arm) -> None:
    fig = draw.capacity_map(arm, GRID, effects=MODEL)
    legend = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert any(t.startswith("F") and "force" in t for t in legend)
    assert "stroke 250–370 mm" in fig.get_suptitle()
    fig = draw.dominant_effect_map(arm, GRID, MODEL, 6.5)
    # the effects' legend (titled), not the key to the arm drawing beside it
    texts = [
        t.get_text() for leg in fig.legends if leg.get_title().get_text() for t in leg.get_texts()
    ]
    names = ["actuator 1 body", "actuator 2 body", "actuator 3 body"]
    names += ["actuator 2 mount", "actuator 3 play", "joint O3 clearance"]
    assert [t.split(":")[0] for t in texts] == names


def test_maps_refuse_a_payload_not_swept_and_a_reduced_sweep(
    ds: xr.Dataset, arm: eodarm.Arm
) -> None:
    with pytest.raises(
        EodarmError, match=r"payload 3 kg is not in the sweep \(mass_kg: 1.5, 6.5\)"
    ):
        draw.sag_map(ds, 3.0)
    red = eodarm.sweep(
        arm, alpha_deg=GRID, mass_kg=[1.0], reduce={"op": "max", "dims": ["mass_kg"]}
    )
    with pytest.raises(EodarmError, match="mass_kg dimension"):
        draw.force_maps(red)


def test_a_map_is_written_only_when_asked(
    ds: xr.Dataset, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    draw.sag_map(ds, 1.5)
    assert list(tmp_path.iterdir()) == []
    draw.sag_map(ds, 1.5, path=tmp_path / "sag.png")
    assert (tmp_path / "sag.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

"""Every command on arms with rotary drives (docs/model.md §10), as a new user runs them.

On the rotary and the mixed example arm: the workflow synth → (records) → compare → diagnose →
fit -o → solve --uncertainty → compensate → sweep (torque map, capacity from
``max_torque_nmm``, ``--cycle``) → report → plan gives answers that are the physics' (a fitted
file solves to the fitted model, a compensated pose lands, a sweep's torque is the solve's, the
capacity is where |T| reaches the limit); and every mistake of kind (a linear actuator's key
on a drive or the reverse, an actuator's effect at a drive or a drive's at an actuator, a
``dlK_mm`` column at a drive, a missing stiffness) is refused in one line naming the file, the
table or flag, and the key.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

import eodarm
from eodarm.cli import main
from eodarm.model.hysteresis import band, reversing_mass

ROOT = Path(__file__).resolve().parents[1]
ROTARY = ROOT / "examples" / "rotary_arm.toml"
MIXED = ROOT / "examples" / "mixed_arm.toml"
ARMS = {"rotary": ROTARY, "mixed": MIXED}
#: A pose of each arm inside every drive's range and every stroke.
POSE = {"rotary": "60,-30,-20", "mixed": "60,-60,-100"}
#: The hidden backlash of each arm's workflow, at a joint with a drive.
HIDDEN = {"rotary": "drive_backlash@O3=0.08", "mixed": "drive_backlash@O1=0.05"}
#: A one-line refusal: shorter than this (docs/terminal.md).
ONE_LINE = 300


def _json(capsys: pytest.CaptureFixture[str], argv: list[str]) -> dict:
    capsys.readouterr()
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("name", list(ARMS))
def test_the_workflow_runs_on_an_arm_with_drives(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    arm_path, pose, hidden = str(ARMS[name]), POSE[name], HIDDEN[name]
    key, value = hidden.split("=")
    arm = eodarm.Arm.from_toml(arm_path)
    meas = tmp_path / "meas.csv"
    assert (
        main(["synth", "--arm", arm_path, "--configs", "8", "--hidden", hidden, "-o", str(meas)])
        == 0
    )
    header = meas.read_text().splitlines()[0].split(",")
    drives = [i + 1 for i, k in enumerate(arm.kinds) if k == "rotary"]
    assert not {f"dl{i}_mm" for i in drives} & set(header)  # a drive has no length channel
    cmp = _json(capsys, ["compare", str(meas), "--arm", arm_path, "--json"])
    assert cmp["chi2_per_dof"] > 10  # the baseline misses the hidden backlash
    d = _json(capsys, ["diagnose", str(meas), "--arm", arm_path, "--json"])
    assert d["verdict"] == "missing" and d["suggested"] == [key]
    fitted = tmp_path / "fitted.toml"
    f = _json(
        capsys, ["fit", str(meas), "--arm", arm_path, "--add", key, "-o", str(fitted), "--json"]
    )
    (eff,) = f["effects"]
    est, err = eff["estimate"]["backlash_deg"], eff["stderr"]["backlash_deg"]
    assert abs(est - float(value)) <= 3 * err
    # the fitted file solves to the fitted model, uncertainty included
    s = _json(
        capsys,
        ["solve", "--arm", str(fitted), "--alpha", pose, "--mass", "5", "--json", "--uncertainty"],
    )
    (p,) = s["poses"]
    direct = eodarm.solve(
        arm,
        [[float(a) for a in pose.split(",")]],
        5.0,
        [eodarm.Effect.parse(key, backlash_deg=est)],
    )
    assert p["dy_mm"] == pytest.approx(float(direct["dy_mm"][0]), abs=1e-9)
    assert p["sigma_dy_mm"] > 0
    assert [t is None for t in p["torque_nmm"]] == [k == "linear" for k in arm.kinds]
    assert [x is None for x in p["force_n"]] == [k == "rotary" for k in arm.kinds]
    # compensation with the fitted model: lands, no length at a drive
    c = _json(
        capsys, ["compensate", "--arm", str(fitted), "--alpha", pose, "--mass", "5", "--json"]
    )
    assert c["status"] == ["ok"] and c["residual_mm"][0] < 1e-6
    assert [x is None for x in c["length_mm"][0]] == [k == "rotary" for k in arm.kinds]
    fit_arm = eodarm.Arm.from_toml(fitted)
    nominal = eodarm.forward(fit_arm, [[float(a) for a in pose.split(",")]], backend="numpy")
    cmd = np.array(c["alpha_deg"])
    loaded = eodarm.solve(fit_arm, cmd, 5.0)
    moved = eodarm.forward(fit_arm, cmd, backend="numpy")["measure"][0]
    landed = moved + np.array([loaded["dx_mm"][0], loaded["dy_mm"][0]])
    assert np.allclose(landed, nominal["measure"][0], atol=1e-6)
    # the report renders: the drives' springs and the found backlash in it
    html = tmp_path / "report.html"
    assert main(["report", str(meas), "--arm", arm_path, "-o", str(html)]) == 0
    text = html.read_text()
    assert "torsional spring" in text and key in text


@pytest.mark.parametrize("name", list(ARMS))
def test_a_load_cycle_and_raw_records_of_an_arm_with_drives(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    arm_path, hidden = str(ARMS[name]), HIDDEN[name]
    key = hidden.split("=")[0]
    seq = tmp_path / "seq.csv"
    argv = ["synth", "--arm", arm_path, "--configs", "4", "--hidden", hidden]
    assert main([*argv, "--sequence", "0,1.5,5,6.5,5,1.5,0", "-o", str(seq)]) == 0
    assert _json(capsys, ["diagnose", str(seq), "--arm", arm_path, "--json"])["suggested"] == [key]
    rec = tmp_path / "rec"
    assert main([*argv, "--records", str(rec)]) == 0
    out = tmp_path / "rec.csv"
    assert main(["records", str(rec / "campaign.toml"), "-o", str(out)]) == 0
    d = _json(capsys, ["diagnose", str(out), "--arm", arm_path, "--json"])
    assert d["suggested"] == [key]


@pytest.mark.parametrize("name", list(ARMS))
def test_the_sweep_gives_the_drives_torques_and_their_capacity(name: str, tmp_path: Path) -> None:
    """A cell's torque is the solve's; the capacity is the payload at which a drive's |T|
    reaches its max_torque_nmm (or an actuator its limit), checked by solving just below and
    just above it."""
    from eodarm.workspace.maps import payload_capacity

    arm = eodarm.Arm.from_toml(ARMS[name])
    a = [float(x) for x in POSE[name].split(",")]
    grid = {f"alpha{i + 1}": [a[i] - 5, a[i], a[i] + 5] for i in range(3)}
    ds = eodarm.sweep(
        arm,
        alpha_deg=grid,
        mass_kg=[1.5, 5.0],
        effects=[eodarm.Effect("joint_friction", "O1", torque_nmm=4000.0)],
    )
    alpha = np.array(np.meshgrid(*grid.values(), indexing="ij")).reshape(3, -1).T
    for m in (1.5, 5.0):
        t = ds["torque_nmm"].sel(mass_kg=m).values.reshape(-1, 3)
        ok = ds["ok"].sel(mass_kg=m).values.reshape(-1)
        ref = eodarm.solve(
            arm, alpha, m, [eodarm.Effect("joint_friction", "O1", torque_nmm=4000.0)]
        )
        rot = np.array(arm.kinds) == "rotary"
        assert ok.any()
        np.testing.assert_allclose(
            t[ok][:, rot], ref["torque_nmm"][ok][:, rot], rtol=1e-9, atol=1e-6
        )
        assert np.isnan(t[:, ~rot]).all()
    cap = payload_capacity(arm, grid)
    labels = cap.attrs["limit_labels"].split(", ")
    c = cap["capacity_kg"].values.reshape(-1)
    lim = cap["limit"].values.reshape(-1)
    torque_bound = [j for j, lb in enumerate(labels) if lb.endswith("torque")]
    for p in np.flatnonzero(np.isin(lim, torque_bound)):
        j = int(labels[lim[p]][1:].split()[0]) - 1
        tmax = arm.actuators[j].max_torque_nmm
        below = eodarm.solve(arm, alpha[p : p + 1], 0.999 * c[p])["torque_nmm"][0, j]
        above = eodarm.solve(arm, alpha[p : p + 1], 1.001 * c[p])["torque_nmm"][0, j]
        assert abs(below) < tmax < abs(above)
    if name == "rotary":
        assert np.isin(lim, torque_bound).any()  # the drives' torques bind on this arm


@pytest.mark.parametrize("name", list(ARMS))
def test_the_sweep_commands_draw_torque_maps(name: str, tmp_path: Path) -> None:
    arm_path = str(ARMS[name])
    a = [float(x) for x in POSE[name].split(",")]
    grid = [f"--alpha{i + 1}={a[i] - 10}:{a[i] + 10}:3" for i in range(3)]
    out = tmp_path / "s.nc"
    plots = tmp_path / "maps"
    assert (
        main(
            [
                "sweep",
                "--arm",
                arm_path,
                *grid,
                "--mass",
                "1.5,5",
                "-o",
                str(out),
                "--plot",
                str(plots),
                "--no-progress",
            ]
        )
        == 0
    )
    assert {p.name for p in plots.iterdir()} >= {"forces.png", "capacity.png"}
    cyc = tmp_path / "c.nc"
    assert (
        main(
            [
                "sweep",
                "--arm",
                arm_path,
                *grid,
                "--mass",
                "5",
                "--cycle",
                "--add",
                HIDDEN[name],
                "-o",
                str(cyc),
                "--no-progress",
            ]
        )
        == 0
    )
    import xarray as xr

    with xr.open_dataset(cyc) as ds:
        back = np.hypot(ds["return_dx_mm"], ds["return_dy_mm"]).values
    # a backlash centred at the reference does not re-centre: the arm does not come back
    assert np.nanmin(back) > 1e-3


@pytest.mark.parametrize(
    ("effect", "name"),
    [
        (eodarm.Effect("drive_friction", "O2", torque_nmm=4000.0), "rotary"),
        (eodarm.Effect("joint_friction", "O3", torque_nmm=3000.0), "rotary"),
        (eodarm.Effect("drive_friction", "O1", torque_nmm=15000.0), "mixed"),
    ],
)
def test_the_hysteresis_band_counts_frictions_at_drives(effect: eodarm.Effect, name: str) -> None:
    """The band of a friction at a drive is not 0, and the reversing payload is heavy enough:
    unloading from ten times heavier leaves the point where it does (every element on its
    unloading branch)."""
    arm = eodarm.Arm.from_toml(ARMS[name])
    alpha = np.array([[float(x) for x in POSE[name].split(",")]])
    b = band(arm, alpha, 5.0, [effect])
    assert b[0] > 0.01  # mm: L/k on a lever of a metre, far above rounding
    big = reversing_mass(arm, alpha, 5.0, [effect])
    assert big[0] > 5.0
    seq = eodarm.solve_sequence(arm, alpha, [[5.0, big[0], 5.0]], [effect])
    far = eodarm.solve_sequence(arm, alpha, [[5.0, 10 * big[0], 5.0]], [effect])
    assert seq["dy_mm"][0, 2] == pytest.approx(far["dy_mm"][0, 2], abs=1e-9)


def test_plan_proposes_the_drive_effects_of_a_rotary_arm(
    capsys: pytest.CaptureFixture[str],
) -> None:
    doc = _json(capsys, ["plan", "--arm", str(ROTARY), "--configs", "4", "--pool", "60", "--json"])
    names = {c["effect"] for c in doc["candidates"]}
    assert {"drive_compliance", "drive_backlash", "drive_friction"} <= names
    assert not {n for n in names if n.startswith(("actuator_", "mount_"))}
    assert "dl1_mm" not in doc["channels"]
    pairs = {frozenset((p["a"], p["b"])) for p in doc["inseparable"]}
    assert frozenset(("joint_friction@O2", "drive_friction@O2")) in pairs  # look-alikes


# ---------------------------------------------------------------------------- bad input
def _refused(capsys: pytest.CaptureFixture[str], argv: list[str], *words: str) -> str:
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and len(err) < ONE_LINE, err
    for w in words:
        assert w in err, (w, err)
    return err


@pytest.mark.parametrize(
    ("path", "old", "new", "words"),
    [
        (
            ROTARY,
            "stiffness_nmm_per_rad = 4.0e7",
            "stiffness_nmm_per_rad = 4.0e7\nmax_force_n = 100.0",
            ("actuator[1].max_force_n", "rotary"),
        ),
        (
            ROTARY,
            "stiffness_nmm_per_rad = 4.0e7",
            "stiffness_n_per_mm = 400.0",
            ("actuator[1].stiffness_n_per_mm",),
        ),
        (
            ROTARY,
            "stiffness_nmm_per_rad = 4.0e7",
            "",
            ("actuator[1].stiffness_nmm_per_rad", "missing"),
        ),
        (
            MIXED,
            "stiffness_n_per_mm = 12000.0",
            "stiffness_n_per_mm = 12000.0\nmax_torque_nmm = 5.0",
            ("actuator[2].max_torque_nmm",),
        ),
        (
            MIXED,
            "stiffness_n_per_mm = 12000.0",
            "stiffness_nmm_per_rad = 12000.0",
            ("actuator[2].stiffness_nmm_per_rad",),
        ),
        (
            MIXED,
            "max_force_n = 6000.0",
            'max_force_n = 6000.0\n\n[[effect]]\neffect = "actuator_compliance"\nat = "M1"\n'
            "stiffness_n_per_mm = 100.0",
            ("effect[1]", "actuator_compliance@M1", "drive_compliance@O1"),
        ),
        (
            MIXED,
            "max_force_n = 6000.0",
            'max_force_n = 6000.0\n\n[[effect]]\neffect = "drive_backlash"\nat = "O2"\n'
            "backlash_deg = 0.1",
            ("effect[1]", "drive_backlash@O2", "actuator_play@M2"),
        ),
    ],
    ids=[
        "force-on-drive",
        "linear-stiffness-on-drive",
        "no-stiffness",
        "torque-on-actuator",
        "drive-stiffness-on-actuator",
        "actuator-effect-at-drive",
        "drive-effect-at-actuator",
    ],
)
def test_an_arm_file_that_mixes_up_the_kinds_is_refused_in_one_line(
    path: Path,
    old: str,
    new: str,
    words: tuple[str, ...],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    text = path.read_text()
    assert old in text
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace(old, new, 1))
    _refused(
        capsys,
        ["solve", "--arm", str(bad), "--alpha", "60,-60,-100", "--mass", "5"],
        "bad.toml",
        *words,
    )


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (
            [
                "solve",
                "--arm",
                str(MIXED),
                "--alpha",
                "60,-60,-100",
                "--add",
                "mount_compliance@M1=100",
            ],
            ("--add", "mount_compliance@M1", "drive_compliance@O1"),
        ),
        (
            [
                "solve",
                "--arm",
                str(MIXED),
                "--alpha",
                "60,-60,-100",
                "--add",
                "drive_friction@O3=100",
            ],
            ("--add", "drive_friction@O3", "actuator_friction@M3"),
        ),
        (
            ["synth", "--arm", str(MIXED), "--configs", "3", "--hidden", "actuator_play@M1=0.1"],
            ("--hidden", "actuator_play@M1", "drive_backlash@O1"),
        ),
        (
            ["synth", "--arm", str(MIXED), "--configs", "3", "--channels", "dx_mm,dl1_mm"],
            ("dl1_mm", "rotary drive"),
        ),
        (
            [
                "sweep",
                "--arm",
                str(ROTARY),
                "--alpha1",
                "60",
                "--alpha2",
                "-30",
                "--alpha3",
                "-20",
                "--add",
                "actuator_friction@M2=10",
            ],
            ("--add", "actuator_friction@M2", "drive_friction@O2"),
        ),
    ],
    ids=[
        "add-actuator-effect-at-drive",
        "add-drive-effect-at-actuator",
        "hidden-play-at-drive",
        "length-channel-of-drive",
        "sweep-add",
    ],
)
def test_an_effect_or_channel_of_the_wrong_kind_is_refused_in_one_line(
    argv: list[str], words: tuple[str, ...], capsys: pytest.CaptureFixture[str]
) -> None:
    _refused(capsys, argv, *words)


@pytest.mark.parametrize("command", ["compare", "diagnose", "fit", "report"])
def test_a_length_column_of_a_drive_is_refused_naming_it(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Data of the linear example arm read with the mixed arm: its dl1_mm belongs to a joint
    the mixed arm turns with a drive."""
    meas = tmp_path / "meas.csv"
    assert (
        main(
            [
                "synth",
                "--arm",
                str(ROOT / "examples" / "example_arm.toml"),
                "--configs",
                "3",
                "-o",
                str(meas),
            ]
        )
        == 0
    )
    assert "dl1_mm" in meas.read_text().splitlines()[0].split(",")
    argv = [command, str(meas), "--arm", str(MIXED)]
    if command == "fit":
        argv += ["--add", "drive_compliance@O1"]
    if command == "report":
        argv += ["-o", str(tmp_path / "r.html")]
    _refused(capsys, argv, "meas.csv", "dl1_mm", "rotary drive")


@pytest.fixture
def forget_user_effects() -> Iterator[None]:
    """The example's effect is forgotten after the test (the registry is the process's: a
    later test must not find it among its candidates)."""
    from eodarm.model import custom

    yield
    custom.unregister("harmonic_soft_band")


@pytest.mark.usefixtures("forget_user_effects")
def test_the_harmonic_drive_example_is_fitted_as_a_user_effect(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """examples/harmonic_drive.py: a soft band below a knee torque, found by diagnose and
    fitted by fit --effects from data synthesised with it hidden (its extra compliance
    within its error, and so its stiffness K1)."""
    example = ROOT / "examples" / "harmonic_drive.py"
    shutil.copy(example, tmp_path / "harmonic_drive.py")
    user = str(tmp_path / "harmonic_drive.py")
    meas = tmp_path / "meas.csv"
    k1, k2 = 1.5e6, eodarm.Arm.from_toml(ROTARY).actuators[2].stiffness_nmm_per_rad
    c = 1.0 / k1 - 1.0 / k2  # the soft band's extra compliance, rad/(N·mm)
    argv = ["synth", "--arm", str(ROTARY), "--effects", user, "--configs", "10"]
    assert main([*argv, "--hidden", f"harmonic_soft_band@O3={c}", "-o", str(meas)]) == 0
    d = _json(capsys, ["diagnose", str(meas), "--arm", str(ROTARY), "--effects", user, "--json"])
    assert d["suggested"] == ["harmonic_soft_band@O3"]
    f = _json(
        capsys,
        [
            "fit",
            str(meas),
            "--arm",
            str(ROTARY),
            "--effects",
            user,
            "--add",
            "harmonic_soft_band@O3",
            "--json",
        ],
    )
    (eff,) = f["effects"]
    (param,) = eff["estimate"]
    est, err = eff["estimate"][param], eff["stderr"][param]
    assert abs(est - c) <= 3 * err and err < 0.1 * c
    assert 1.0 / (est + 1.0 / k2) == pytest.approx(k1, rel=0.05)  # K1 recovered
    assert 0.6 < f["after"]["chi2_per_dof"] < 1.5

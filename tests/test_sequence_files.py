"""The ``step`` column of the measurement file: load sequences (docs/formats.md)."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from eodarm.data.measurements import MeasurementFileError
from eodarm.data.reader import read_measurements

HEADER = "config,alpha1_deg,alpha2_deg,alpha3_deg,mass_kg,step,dy_mm,dl2_mm\n"


def _write(tmp_path: Path, body: str, header: str = HEADER) -> Path:
    p = tmp_path / "cycle.csv"
    p.write_text(header + body, encoding="utf-8")
    return p


def test_each_label_is_one_sequence_in_step_order(tmp_path: Path) -> None:
    body = (
        "c1,90,10,0,5.0,2,-1.1,-0.02\n"  # line 2: written out of order
        "c1,90,10,0,0,0,0,\n"  # line 3: the written reference
        "c1,90,10,0,1.5,1,-0.3,-0.01\n"
        "c1,90,10,0,0,3,-0.05,-0.004\n"  # the return: mass 0 is a state
        "c2,70,20,-10,1.5,1,-0.2,\n"
    )
    meas = read_measurements(_write(tmp_path, body), 3)
    assert meas.has_sequences
    seqs = meas.sequences()
    assert [meas.line[s].tolist() for s in seqs] == [[4, 2, 5], [6]]
    # the reference row is kept as a row but carries no value
    assert meas.reference.tolist() == [False, True, False, False, False]
    assert not np.isfinite(meas.values[1]).any()
    assert meas.values[3, meas.index("dy_mm")] == pytest.approx(-0.05, abs=0)


def test_file_without_step_keeps_its_meaning(tmp_path: Path) -> None:
    header = "config,alpha1_deg,alpha2_deg,alpha3_deg,mass_kg,dy_mm\n"
    meas = read_measurements(_write(tmp_path, "c1,90,10,0,5,-1\nc1,90,10,0,0,0\n", header), 3)
    assert not meas.has_sequences and meas.step is None
    assert [s.tolist() for s in meas.sequences()] == [[0], [1]]
    assert not meas.reference.any()
    assert meas.values[1, meas.index("dy_mm")] == 0.0  # a measured zero, not a reference


@pytest.mark.parametrize(
    ("body", "line", "words"),
    [
        ("c1,90,10,0,1.5,1,-0.3,\nc1,90,10,0,5,1,-1,\n", 3, ["step 1 repeats", "line 2"]),
        ("c1,90,10,0,1.5,1,-0.3,\nc1,91,10,0,5,2,-1,\n", 3, ["angles", "91"]),
        ("c1,90,10,0,1.5,1,-0.3,\nc1,90,10,0,5,,-1,\n", 3, ["step is empty"]),
        ("c1,90,10,0,1.5,-1,-0.3,\n", 2, ["step '-1'"]),
        ("c1,90,10,0,1.5,1.5,-0.3,\n", 2, ["step '1.5'"]),
        ("c1,90,10,0,1.5,one,-0.3,\n", 2, ["step 'one'"]),
        ("c1,90,10,0,0,0,0.02,\nc1,90,10,0,5,1,-1,\n", 2, ["reference", "dy_mm is 0.02"]),
    ],
)
def test_bad_sequences_are_refused_in_one_line(
    tmp_path: Path, body: str, line: int, words: list[str]
) -> None:
    with pytest.raises(MeasurementFileError) as err:
        read_measurements(_write(tmp_path, body), 3)
    msg = str(err.value)
    assert "\n" not in msg
    assert "cycle.csv" in msg and f"line {line}:" in msg
    for w in words:
        assert w in msg


def _cycles(labels: list[str], noise: float, hysteresis: float) -> str:
    """Repeated cycles 5 → 10 → 5 → 0 kg at one pose; the unloading branch sits
    ``hysteresis`` mm above the loading one (friction), each value with its own noise."""
    rng = np.random.default_rng(0)
    rows = []
    for label in labels:
        for step, (m, y) in enumerate(
            [(5.0, -1.0), (10.0, -2.0), (5.0, -1.0 + hysteresis), (0.0, hysteresis)], 1
        ):
            rows.append(f"{label},90,10,0,{m},{step},{y + noise * rng.standard_normal():.6f},\n")
    return "".join(rows)


def test_repeats_share_the_payloads_before_them(tmp_path: Path) -> None:
    """Three cycles under three labels are repeats of each other, state by state; the 5 kg
    of the loading and of the unloading branch are not (what came before differs), so the
    pooled σ is the noise, not the hysteresis."""
    meas = read_measurements(_write(tmp_path, _cycles(["a", "b", "c"], 0.002, 0.1)), 3)
    rec = meas.noise["dy_mm"]
    assert rec.source == "repeats"
    assert rec.states == 4 and rec.repeat_dof == 8
    assert 0.0005 < rec.sigma < 0.006  # 0.002 mm of noise, 8 dof; hysteresis is 0.1 mm


def test_one_cycle_has_no_repeats(tmp_path: Path) -> None:
    meas = read_measurements(_write(tmp_path, _cycles(["a"], 0.002, 0.1)), 3)
    assert meas.noise["dy_mm"].source == "default"
    assert meas.noise["dy_mm"].repeat_dof == 0


def test_sequence_file_round_trip(tmp_path: Path) -> None:
    body = "c1,90,10,0,0,0,,\nc1,90,10,0,1.5,1,-0.3,-0.01\nc1,90,10,0,0,2,-0.05,\n"
    meas = read_measurements(_write(tmp_path, body), 3)
    buf = io.StringIO()
    meas.to_csv(buf)
    again = read_measurements(io.StringIO(buf.getvalue()), 3)
    assert again.step is not None and meas.step is not None
    assert again.step.tolist() == meas.step.tolist() == [0, 1, 2]
    assert again.reference.tolist() == [True, False, False]
    np.testing.assert_array_equal(again.values, meas.values)
    sub = meas.subset(np.array([1, 2]))
    assert sub.step is not None and sub.step.tolist() == [1, 2]


def test_synth_sequence_writes_load_cycles(tmp_path: Path) -> None:
    """`eodarm synth --sequence 0,1.5,5,6.5,5,1.5,0`: each configuration one sequence, the
    leading 0 the reference (not written), steps from 1, the values those of
    ``solve_sequence`` with the hidden effect (noise 1e-5 of the defaults)."""
    import eodarm
    from eodarm.cli import main

    out = tmp_path / "cycle.csv"
    arm_file = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
    code = main(
        [
            "synth", "--arm", str(arm_file), "--configs", "3",
            "--sequence", "0,1.5,5,6.5,5,1.5,0", "--hidden", "actuator_friction@M2=60",
            "--noise", "1e-5", "-o", str(out),
        ]
    )  # fmt: skip
    assert code == 0
    meas = read_measurements(out, 3)
    assert meas.has_sequences and meas.step is not None
    seqs = meas.sequences()
    assert len(seqs) == 3
    for rows in seqs:
        assert meas.step[rows].tolist() == [1, 2, 3, 4, 5, 6]
        assert meas.mass_kg[rows].tolist() == [1.5, 5.0, 6.5, 5.0, 1.5, 0.0]
    arm = eodarm.Arm.from_toml(arm_file)
    first = np.array([rows[0] for rows in seqs])
    truth = eodarm.solve_sequence(
        arm,
        meas.alpha_deg[first],
        [1.5, 5.0, 6.5, 5.0, 1.5, 0.0],
        effects=[eodarm.Effect("actuator_friction", "M2", friction_n=60.0)],
        backend="numpy",
    )
    got = np.array([meas.values[rows, meas.index("dl2_mm")] for rows in seqs])
    # noise 1e-5 of the 0.002 mm default (2e-8 mm): equal to 1e-6 mm, 50 sigma
    np.testing.assert_allclose(got, truth["dl_mm"][:, :, 1], rtol=0, atol=1e-6)
    assert np.all(np.abs(got[:, -1]) > 0.01)  # 60 N over 2500 N/mm stays at the return

//! Angles from actuator lengths in batches: the same as one row at a time, NaN exactly where a
//! row cannot close (with `nan_on_failure`), one shared reference pose the same as that pose
//! repeated, the parallel path the same as the serial one, and the first failing row named.

#![allow(clippy::unwrap_used)] // test code: a failure should panic
use arm_core::examples::example_arm;
use arm_core::kinematics::{angles_from_lengths, angles_from_lengths_batch, Frames};
use arm_core::ArmError;

/// Lengths of `rows` poses around the example's reference pose, every few rows one that
/// cannot close (too long for its triangle).
fn lengths(rows: usize) -> (Vec<f64>, Vec<bool>) {
    let arm = example_arm();
    let mut fr = Frames::new(3);
    let (mut out, mut closes) = (Vec::new(), Vec::new());
    for r in 0..rows {
        let t = r as f64 / rows as f64;
        let alpha = [
            (60.0 + 50.0 * t).to_radians(),
            (30.0 * (7.0 * t).sin().abs()).to_radians(),
            (-10.0 + 20.0 * (3.0 * t).fract()).to_radians(),
        ];
        fr.fill(&arm, &alpha);
        let bad = r % 7 == 3;
        for i in 0..3 {
            out.push(if bad && i == r % 3 {
                5000.0
            } else {
                fr.length(i)
            });
        }
        closes.push(!bad);
    }
    (out, closes)
}

#[test]
fn batches_equal_single_rows_and_mark_failures_with_nan() {
    let arm = example_arm();
    let ref_deg = [90.0, 10.0, 0.0];
    let ref_rad: Vec<f64> = ref_deg.iter().map(|d: &f64| d.to_radians()).collect();
    for rows in [50, 3 * 4096 + 17] {
        let (len, closes) = lengths(rows);
        let mut got = vec![0.0; rows * 3];
        angles_from_lengths_batch(&arm, &len, &ref_deg, true, &mut got).unwrap();
        let repeated: Vec<f64> = ref_deg.iter().copied().cycle().take(rows * 3).collect();
        let mut per_row_ref = vec![0.0; rows * 3];
        angles_from_lengths_batch(&arm, &len, &repeated, true, &mut per_row_ref).unwrap();
        assert_eq!(
            got.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            per_row_ref.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        let mut one = [0.0; 3];
        for r in 0..rows {
            let row = &got[3 * r..3 * r + 3];
            match angles_from_lengths(&arm, &len[3 * r..3 * r + 3], &ref_rad, r, &mut one) {
                Ok(()) => {
                    assert!(closes[r], "row {r} closes");
                    for i in 0..3 {
                        assert_eq!(row[i].to_bits(), one[i].to_degrees().to_bits(), "row {r}");
                    }
                }
                Err(ArmError::Unreachable { row: e, .. }) => {
                    assert!(!closes[r] && e == r, "row {r}");
                    assert!(row.iter().all(|v| v.is_nan()), "row {r}: {row:?}");
                }
                Err(e) => panic!("row {r}: {e}"),
            }
        }
        // Without nan_on_failure: the first row that cannot close is the error.
        let e = angles_from_lengths_batch(&arm, &len, &ref_deg, false, &mut got).unwrap_err();
        assert!(matches!(e, ArmError::Unreachable { row: 3, .. }), "{e}");
    }
}

#[test]
fn bad_batches_are_errors_naming_the_row() {
    let arm = example_arm();
    let (mut len, _) = lengths(10_000);
    len[3 * 9000 + 1] = f64::NAN;
    let mut out = vec![0.0; len.len()];
    let e = angles_from_lengths_batch(&arm, &len, &[90.0, 10.0, 0.0], true, &mut out).unwrap_err();
    assert!(matches!(e, ArmError::NonFinite { row: 9000, .. }), "{e}");
    len[3 * 9000 + 1] = 300.0;
    len[3 * 8000] = -1.0;
    let e = angles_from_lengths_batch(&arm, &len, &[90.0, 10.0, 0.0], true, &mut out).unwrap_err();
    assert!(matches!(e, ArmError::OutOfRange { row: 8000, .. }), "{e}");
    let e = angles_from_lengths_batch(&arm, &len, &[90.0, 10.0], true, &mut out).unwrap_err();
    assert!(
        matches!(
            e,
            ArmError::Shape {
                what: "alpha_ref_deg",
                ..
            }
        ),
        "{e}"
    );
}

/// `forward_batch` (parallel chunks) gives each row's `Frames::fill`, bit for bit, and names
/// the first row with a non-finite angle, also beyond the first chunk.
#[test]
fn forward_batch_is_frames_fill_per_row() {
    use arm_core::kinematics::{forward_batch, ForwardOutput};
    let arm = example_arm();
    let (n, rows) = (arm.n(), 3000);
    let alpha: Vec<f64> = (0..rows * n)
        .map(|k| [80.0, 10.0, -5.0][k % n] + (k as f64 * 0.37).sin() * 20.0)
        .collect();
    let mut o = vec![0.0; rows * (n + 1) * 2];
    let mut a = vec![0.0; rows * n * 2];
    let mut b = vec![0.0; rows * n * 2];
    let mut c = vec![0.0; rows * n * 2];
    let mut m = vec![0.0; rows * 2];
    let mut len = vec![0.0; rows * n];
    let mut run = |alpha: &[f64]| {
        let out = ForwardOutput {
            o: &mut o,
            a: &mut a,
            b: &mut b,
            c: &mut c,
            measure: &mut m,
            length: &mut len,
        };
        forward_batch(&arm, alpha, out)
    };
    let mut bad = alpha.clone();
    bad[2500 * n + 1] = f64::NAN;
    let err = run(&bad).unwrap_err();
    assert!(err.to_string().contains("row 2500"), "{err}");
    run(&alpha).unwrap();
    let mut fr = Frames::new(n);
    for row in [0, 1, 1023, 1024, 2999] {
        let rad: Vec<f64> = alpha[row * n..(row + 1) * n]
            .iter()
            .map(|d| d.to_radians())
            .collect();
        fr.fill(&arm, &rad);
        for i in 0..n {
            assert_eq!(a[2 * (row * n + i)], fr.a[i].x);
            assert_eq!(b[2 * (row * n + i) + 1], fr.b[i].y);
            assert_eq!(c[2 * (row * n + i)], fr.c[i].x);
            assert_eq!(len[row * n + i], fr.length(i));
        }
        assert_eq!(o[2 * (row * (n + 1) + n)], fr.joint[n].x);
        assert_eq!(m[2 * row + 1], fr.measure.y);
    }
}

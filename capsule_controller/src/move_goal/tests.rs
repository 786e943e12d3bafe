use super::*;

const PERIOD: f64 = 0.1;

fn request(distance_m: f64) -> MoveRequest {
    MoveRequest {
        distance_m,
        tolerance_m: 0.0,
        timeout_s: 0.0,
    }
}

/// A fake plant sampled 20 times per period: each period the capsule moves `slope * k_p`
/// (the gain held at the period's start), times `gain_error`, in one jump at mid-period.
/// Returns the gains held, one per sample, until the goal ends or `periods` pass.
fn drive(run: &mut MoveRun, slope: f64, gain_error: f64, periods: usize) -> Vec<f64> {
    let mut x2 = 0.3;
    let mut gains = Vec::new();
    let mut held = 0.0;
    for n in 0..periods {
        for k in 0..20 {
            let t = 7.0 + (n * 20 + k) as f64 * PERIOD / 20.0 + 1e-6;
            if k == 10 {
                x2 += slope * gain_error * held;
            }
            let g = run.sample(t, x2);
            if k == 0 {
                held = g;
            }
            gains.push(g);
            if run.outcome().is_some() {
                return gains;
            }
        }
    }
    gains
}

#[test]
fn bad_goals_are_refused_with_the_field_and_the_reason() {
    let c = MoveConfig::DEFAULT;
    let refused = |r: MoveRequest| {
        MoveRun::start(r, c, PERIOD)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default()
    };
    assert_eq!(refused(request(f64::NAN)), "distance_m = NaN is not finite");
    assert_eq!(
        refused(request(f64::NEG_INFINITY)),
        "distance_m = -inf is not finite"
    );
    assert!(refused(request(10.5))
        .starts_with("distance_m = 10.5 is beyond the configured limit of 10 m"));
    for tolerance_m in [-1e-3, f64::NAN] {
        assert!(refused(MoveRequest {
            tolerance_m,
            ..request(0.01)
        })
        .starts_with("tolerance_m = "));
    }
    for timeout_s in [-1.0, f64::INFINITY] {
        assert!(refused(MoveRequest {
            timeout_s,
            ..request(0.01)
        })
        .starts_with("timeout_s = "));
    }
    let ok = MoveRun::start(request(-0.01), c, PERIOD).map(|r| r.tolerance_m());
    assert_eq!(ok, Ok(c.default_tolerance_m));
}

#[test]
fn a_linear_plant_is_reached_forward_and_backward_within_the_tolerance_and_left_off() {
    for (distance, gain_error) in [(0.01, 1.0), (-0.005, 1.0), (0.02, 0.7), (-0.013, 1.4)] {
        let mut run = MoveRun::start(request(distance), MoveConfig::DEFAULT, PERIOD)
            .unwrap_or_else(|e| panic!("{e}"));
        // 1.5 mm per period at the cruise gain 0.2, as at the section-5 control point
        let gains = drive(&mut run, 7.5e-3, gain_error, 200);
        let out = run.outcome().cloned();
        let Some(out) = out else {
            panic!("{distance}: no end after 200 periods")
        };
        assert_eq!(out.end, MoveEnd::Reached, "{distance}: {out:?}");
        assert!(out.error_m.abs() <= 1e-3, "{distance}: {out:?}");
        assert_eq!(gains.last(), Some(&0.0), "ends OFF");
        assert!(gains.iter().all(|g| g.abs() <= 0.2 + 1e-12));
        assert!(
            gains.iter().all(|g| *g * distance >= 0.0),
            "{distance}: never drives away from the target"
        );
        // full speed far away, slower near the target
        let periods = gains.len() / 20;
        assert!(periods < 40, "{distance}: {periods} periods");
        assert!(out.message(distance).starts_with("reached: travelled "));
    }
}

#[test]
fn the_first_period_is_off_and_the_travel_counts_from_the_first_section() {
    let mut run = MoveRun::start(request(0.01), MoveConfig::DEFAULT, PERIOD)
        .unwrap_or_else(|e| panic!("{e}"));
    // mid-period: OFF until the next section crossing, which is the reference
    assert_eq!(run.sample(7.05, 1.0), 0.0);
    assert_eq!(run.sample(7.08, 1.2), 0.0);
    assert_eq!(run.progress().travelled_m, 0.0);
    let g = run.sample(7.1 + 1e-6, 1.3);
    assert_eq!(
        g,
        MoveConfig::DEFAULT.cruise_gain,
        "cruising far from the target"
    );
    run.sample(7.15, 1.301);
    assert!((run.progress().travelled_m - 0.001).abs() < 1e-12);
    assert!((run.progress().remaining_m - 0.009).abs() < 1e-12);
}

#[test]
fn cancel_timeout_stall_and_abort_end_the_goal_off() {
    let c = MoveConfig::DEFAULT;
    let mut run = MoveRun::start(request(0.05), c, PERIOD).unwrap_or_else(|e| panic!("{e}"));
    drive(&mut run, 7.5e-3, 1.0, 5);
    assert!(run.outcome().is_none());
    run.cancel();
    assert_eq!(run.outcome().map(|o| &o.end), Some(&MoveEnd::Canceled));
    assert_eq!(run.sample(100.0, 0.0), 0.0, "OFF after the end");
    run.abort("late".into());
    assert_eq!(
        run.outcome().map(|o| &o.end),
        Some(&MoveEnd::Canceled),
        "the first end stays"
    );

    let mut run = MoveRun::start(
        MoveRequest {
            timeout_s: 0.5,
            ..request(0.05)
        },
        c,
        PERIOD,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let gains = drive(&mut run, 7.5e-3, 1.0, 100);
    let out = run.outcome().cloned();
    assert!(
        matches!(&out, Some(MoveOutcome { end: MoveEnd::Aborted(why), elapsed_s, .. })
            if why.starts_with("timeout") && (*elapsed_s - 0.5).abs() < 0.01),
        "{out:?}"
    );
    assert_eq!(gains.last(), Some(&0.0));

    // a capsule that does not move at all
    let mut run = MoveRun::start(request(0.05), c, PERIOD).unwrap_or_else(|e| panic!("{e}"));
    let gains = drive(&mut run, 0.0, 1.0, 100);
    let out = run.outcome().cloned();
    assert!(
        matches!(&out, Some(MoveOutcome { end: MoveEnd::Aborted(why), .. }) if why.starts_with("no progress")),
        "{out:?}"
    );
    assert!(gains.len() / 20 <= c.stall_periods as usize + 2);

    let mut run = MoveRun::start(request(0.05), c, PERIOD).unwrap_or_else(|e| panic!("{e}"));
    drive(&mut run, 7.5e-3, 1.0, 3);
    run.abort("set_mode OFF".into());
    let out = run.outcome().cloned().map(|o| o.message(0.05));
    assert!(
        out.as_deref()
            .is_some_and(|m| m.starts_with("aborted: set_mode OFF; travelled ")),
        "{out:?}"
    );
}

#[test]
fn a_goal_within_the_tolerance_ends_reached_without_driving() {
    let mut run = MoveRun::start(
        MoveRequest {
            tolerance_m: 2e-3,
            ..request(4e-4)
        },
        MoveConfig::DEFAULT,
        PERIOD,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let gains = drive(&mut run, 7.5e-3, 1.0, 10);
    assert_eq!(run.outcome().map(|o| &o.end), Some(&MoveEnd::Reached));
    assert!(gains.iter().all(|g| *g == 0.0));
}

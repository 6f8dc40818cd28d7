//! A model whose own names are those of the methods' arguments (a state `y`, like the
//! measurement `y`): the generated methods still read and test their arguments, and a
//! non-finite one is `RejectedInput`, the filter unchanged.

stateforge::model! {
    /// A cart whose position is `y`, slowed by an unknown drag `t_prev`, pushed by `u`.
    mod named_like_arguments {
        scalar f32, f64;
        const TS = 0.01;
        state y, v;
        param t_prev;
        input u;
        output position = y, speed_squared = v * v;
        generate ekf(process_noise = diagonal),
            ekf(process_noise = diagonal, gate = 20.0, name = GatedEkf);
        dynamics discrete {
            y = y + TS * v;
            v = v + TS * (u - t_prev * v);
        }
    }
}

macro_rules! check_filter {
    ($filter:ty, $scalar:ty, $status:ty) => {{
        let p0: [[$scalar; 3]; 3] = [[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.01]];
        let mut filter = <$filter>::new(
            &[0.0, 0.1, 0.5],
            &p0,
            &[1e-6, 1e-4, 1e-6],
            &[[1e-4, 0.0], [0.0, 1e-2]],
        )
        .unwrap();
        for k in 1..50 {
            let t = k as $scalar * 0.01;
            assert_eq!(filter.step(&[1.0], &[0.1 * t, 0.01]), <$status>::Ok);
        }
        let before = filter;
        for bad in [<$scalar>::NAN, <$scalar>::INFINITY, <$scalar>::NEG_INFINITY] {
            assert_eq!(filter.step(&[bad], &[0.5, 0.01]), <$status>::RejectedInput);
            assert_eq!(filter.step(&[1.0], &[bad, 0.01]), <$status>::RejectedInput);
            assert_eq!(filter.step(&[1.0], &[0.5, bad]), <$status>::RejectedInput);
            assert_eq!(filter.predict(&[bad]), <$status>::RejectedInput);
            assert_eq!(filter.update(&[0.5, bad]), <$status>::RejectedInput);
            assert_eq!(filter.update_position(bad), <$status>::RejectedInput);
            assert_eq!(filter, before);
        }
    }};
}

#[test]
fn arguments_named_like_the_model_are_still_tested() {
    use named_like_arguments::{in_f64, Ekf, GatedEkf, Status};
    check_filter!(Ekf, f32, Status);
    check_filter!(GatedEkf, f32, Status);
    check_filter!(in_f64::Ekf, f64, in_f64::Status);
    check_filter!(in_f64::GatedEkf, f64, in_f64::Status);
}

stateforge::model! {
    /// A filter fused as a flight stack runs it: a budget per call and a rate schedule
    /// within its load at the clock. Compiles; the estimates checked are its constants.
    pub mod tracked {
        scalar f32, f64;
        const DT = 0.004;
        state p, v;
        input a;
        output fix = p, speed = v;
        sensor gnss = [fix];
        sensor odometer = [speed];
        generate ekf(process_noise = diagonal,
            max_cycles = [predict = 2000, update_gnss = 2000, update_odometer = 2000],
            schedule = [predict = 250, update_gnss = 5, update_odometer = 50],
            mhz = 168, max_load = 1);
        dynamics discrete {
            p = p + DT * v;
            v = v + DT * a;
        }
    }
}

const _: () = assert!(tracked::EKF_PREDICT_CYCLES <= 2000);
const _: () = assert!(tracked::EKF_UPDATE_GNSS_CYCLES <= 2000);
// 250 Hz x predict + 5 Hz x update_gnss + 50 Hz x update_odometer within 1 % of 168 MHz.
const _: () = assert!(
    250 * tracked::EKF_PREDICT_CYCLES
        + 5 * tracked::EKF_UPDATE_GNSS_CYCLES
        + 50 * tracked::EKF_UPDATE_ODOMETER_CYCLES
        <= 1_680_000
);

fn main() {}

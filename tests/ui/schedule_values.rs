stateforge::model! {
    /// Wrong schedules and per-call budgets are reported under the value, several at once.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        input u;
        output y = x1;
        generate ekf(schedule = [predict = 100, step = 100], name = NoClock),
            ekf(schedule = [predict = 0], mhz = 168, name = ZeroRate),
            ekf(schedule = [predict = 100, predict = 50], mhz = 168, name = Twice),
            ekf(schedule = 100, mhz = 168, name = NotATable),
            ekf(schedule = [predict = 100], mhz = 168, max_load = 150, name = OverFull),
            ekf(max_load = 50, name = NoSchedule),
            ekf(max_cycles = [predict = -1], name = NegativeCall),
            ekf(max_cycles = [predict = 100, update = 100, predict = 200], name = CallTwice);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * u;
        }
    }
}

fn main() {}

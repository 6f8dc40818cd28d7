// `tracked_outputs` names outputs, each once.
stateforge::model! {
    pub mod names {
        scalar f64;
        const TS = 0.1;
        state x1, x2;
        input u;
        output y = x1;
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * u;
        }
        generate mpc(horizon = 4, states = [x1, x2], input = u,
            tracked_outputs = [y, x2, y]);
    }
}

// A tracked output must be linear in the regulated states.
stateforge::model! {
    pub mod offset {
        scalar f64;
        const TS = 0.1;
        state x1, x2;
        input u;
        output y = x1 + 1.0;
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * u;
        }
        generate mpc(horizon = 4, states = [x1, x2], input = u, tracked_outputs = [y]);
    }
}

// The steady state is computed when the model is compiled: the dynamics must be affine.
stateforge::model! {
    pub mod pendulum {
        scalar f64;
        const TS = 0.01;
        state angle, rate;
        input torque;
        output y = angle;
        dynamics discrete {
            angle = angle + TS * rate;
            rate = rate - TS * 9.81 * sin(angle) + TS * torque;
        }
        generate mpc(horizon = 4, states = [angle, rate], input = torque,
            tracked_outputs = [y]);
    }
}

// One input cannot hold two outputs at independent values: the position and the speed
// of a double integrator (at rest in every steady state).
stateforge::model! {
    pub mod two_outputs {
        scalar f64;
        const TS = 0.1;
        state x1, x2;
        input u;
        output position = x1, speed = x2;
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * u;
        }
        generate mpc(horizon = 4, states = [x1, x2], input = u,
            tracked_outputs = [position, speed]);
    }
}

// A branch is not affine, though its derivatives are constants on each side: Coulomb
// friction's force jumps at zero speed.
stateforge::model! {
    pub mod friction {
        scalar f64;
        const TS = 0.1;
        state x1, x2;
        input u;
        output y = x1;
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * (u - if x2 > 0.0 { 0.3 } else { -0.3 });
        }
        generate mpc(horizon = 4, states = [x1, x2], input = u, tracked_outputs = [y]);
    }
}

// A model so small in every coefficient that its steady state is beyond `f32`: `x1` is
// 1e33 times the output held.
stateforge::model! {
    pub mod faint {
        scalar f32, f64;
        const TINY = 1e-33;
        state x1, x2;
        input u;
        output y = TINY * x1;
        dynamics discrete {
            x1 = x1 + TINY * x2;
            x2 = x2 + TINY * u;
        }
        generate mpc(horizon = 4, states = [x1, x2], input = u, tracked_outputs = [y]);
    }
}

fn main() {}

//! Motion between impacts, in closed form and `f64`, with no rapier types: free flight
//! ([`flight`]: exact ballistics under constant force and damping, torque-free rotation) and a
//! ball sliding and rolling on a plane ([`rolling`]), and when two moving balls first touch
//! ([`meeting`]). The adapter flies bodies with it between
//! the model's impacts (`crate::model`).

pub(crate) mod flight;
pub(crate) mod meeting;
pub(crate) mod pursuit;
pub(crate) mod rolling;

pub(crate) use flight::{Flight, Gyro, State};
pub(crate) use meeting::{Motion, Moving};
pub(crate) use rolling::Rolling;

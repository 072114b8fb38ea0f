//! Prediction of the feed the machine really reaches (`../shared/DOMAIN.md` §4–5).
//!
//! Work in progress (issue #5): so far the per-block limits of the inverse-time model
//! ([`block`]), the corner speed at block transitions ([`corner`]) and the rest-to-rest
//! jerk-limited motion ([`profile`]). The look-ahead planner, the relative tool/surface feed,
//! VPOp and the outputs build on them; nothing calls this crate yet.

pub mod block;
pub mod corner;
pub mod profile;

pub use block::{BlockLimits, Limiter, block_limits};
pub use corner::{blend_radius, corner_speed, interior_angle};
pub use profile::{Profile, State, speed_change};

//! Read-only questions the stages share: contact geometry along a flight and the time of
//! impact (`geometry.rs`), between two moving bodies (`body_contact.rs`), which grounds a body
//! may meet (`ground_index.rs`) and the tiled floors that are one box to it (`slabs.rs`),
//! rapier's own pair filtering (`filter.rs`), what the step reads of rapier (`observe.rs`),
//! and whether anything besides its grounds can reach a rolling ball (`reach.rs`); where
//! rapier will have a collider ([`collider_pose`]). Nothing here writes rapier or the
//! plugin's state, but for the reach test's memo of the neighbouring balls it read in the
//! current plan.

pub(crate) mod body_contact;
pub(crate) mod filter;
pub(crate) mod geometry;
pub(crate) mod ground_index;
pub(crate) mod observe;
pub(crate) mod reach;
pub(crate) mod slabs;

use crate::rapier::math::Pose;
use crate::rapier::prelude::Collider;

/// A collider's pose as rapier will have it once its step starts: its body's pose `frame`
/// (as rapier or the step's writes hold it; `None` for a collider without a body) times its
/// pose on the body, the product rapier itself forms. rapier moves a body's colliders only
/// inside its step, so `Collider::position` still says where a body moved since (by the
/// user, or by the plugin's writes after the last step) was. Bit for bit that position for a
/// body that has not moved.
#[inline]
pub(crate) fn collider_pose(co: &Collider, frame: Option<&Pose>) -> Pose {
    match (frame, co.position_wrt_parent()) {
        (Some(frame), Some(local)) => *frame * *local,
        _ => *co.position(),
    }
}

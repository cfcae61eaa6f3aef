//! [`ImpactDebugPlugin`]: the impacts of the last moments drawn with Bevy's gizmos.
//!
//! Contract: with Bevy's `GizmoPlugin` in the app (it is in `DefaultPlugins`; a headless app
//! adds `AssetPlugin`, `MeshPlugin` and `GizmoPlugin` to `MinimalPlugins`, which Bevy's gizmos
//! need), every [`ImpactMessage`] is drawn
//! in the gizmo group [`ImpactGizmos`] from the frame it is read (in `PostUpdate`, after
//! [`crate::ImpactSet::Step`]) for [`ImpactGizmos::lifetime`] seconds of `Time`: a circle
//! around the contact point in the contact plane, the contact normal, and the impulse on the
//! body as an arrow. Without `GizmoPlugin` the plugin adds no system: nothing is drawn, and
//! nothing fails. It reads the messages only; the simulation is the same with or without it.

use crate::messages::ImpactMessage;
use crate::plugin::ImpactSet;
use bevy::color::Color;
use bevy::color::palettes::css::{GOLD, LIME, ORANGE_RED};
use bevy::gizmos::config::GizmoConfigGroup;
use bevy::gizmos::gizmos::Gizmos;
use bevy::gizmos::{AppGizmoBuilder, GizmoPlugin};
use bevy::prelude::*;
use rapier_impact::EventKind;

/// Draws the impacts with Bevy's gizmos (see [`ImpactGizmos`] for what and how long). Optional:
/// add it beside [`crate::RapierImpactPlugin`] (in any order) to see the impacts. It needs
/// Bevy's `GizmoPlugin` to draw (in `DefaultPlugins`; beside `MinimalPlugins`, add
/// `bevy::asset::AssetPlugin`, `bevy::mesh::MeshPlugin` and `bevy::gizmos::GizmoPlugin`), and
/// does nothing without it. It comes with the crate's `debug-plugin` feature (on by default),
/// which turns on Bevy's `bevy_gizmos` feature (no renderer).
///
/// ```no_run
/// use bevy::prelude::*;
/// use bevy_rapier3d::prelude::NoUserData;
/// use bevy_rapier_impact::{ImpactConfig, ImpactDebugPlugin, ImpactGizmos, RapierImpactPlugin};
///
/// App::new()
///     .add_plugins(DefaultPlugins)
///     .add_plugins(RapierImpactPlugin::<NoUserData>::new(ImpactConfig::default()).unwrap())
///     .add_plugins(ImpactDebugPlugin)
///     .add_systems(Startup, |mut store: ResMut<GizmoConfigStore>| {
///         // Each impact drawn for 2 s, its impulse at 0.5 m per N s.
///         let (_, impacts) = store.config_mut::<ImpactGizmos>();
///         impacts.lifetime = 2.0;
///         impacts.impulse_scale = 0.5;
///     })
///     .run();
/// ```
#[derive(Clone, Copy, Debug, Default)]
pub struct ImpactDebugPlugin;

impl Plugin for ImpactDebugPlugin {
    fn build(&self, app: &mut App) {
        // The message may come before or after the impact plugin: registering it is idempotent.
        app.add_message::<ImpactMessage>()
            .register_type::<ImpactGizmos>();
    }

    fn finish(&self, app: &mut App) {
        // Every plugin is built by now, whatever the order they were added in.
        if !app.is_plugin_added::<GizmoPlugin>() {
            return;
        }
        app.init_gizmo_group::<ImpactGizmos>()
            .add_systems(PostUpdate, draw_impacts.after(ImpactSet::Step));
    }
}

/// The gizmo group of the impacts, with how they are drawn: its `GizmoConfig` (Bevy's:
/// `enabled`, line width, depth bias, render layers) and these fields are in Bevy's
/// `GizmoConfigStore` (`store.config_mut::<ImpactGizmos>()`). Reflected (an inspector edits
/// every field).
#[derive(Reflect, GizmoConfigGroup, Clone, Debug, PartialEq)]
#[reflect(Default, Debug, PartialEq, Clone)]
pub struct ImpactGizmos {
    /// How long each impact stays drawn, in seconds of `Time` (default 1 s; 0: only in the
    /// frame it is read).
    pub lifetime: f32,
    /// Radius of the circle drawn around the contact point, in the contact plane (m, default
    /// 0.05).
    pub point_radius: f32,
    /// Length of the contact normal's line (m, default 0.25).
    pub normal_length: f32,
    /// Length of the impulse arrow per unit of impulse (m per N s, default 1).
    pub impulse_scale: f32,
    /// Draw the corrections too (settles, push-outs, energy caps, holds, releases:
    /// `rapier_impact::EventKind`), not only the impacts (default `false`).
    pub corrections: bool,
    /// Color of the contact point's circle.
    pub point_color: Color,
    /// Color of the normal.
    pub normal_color: Color,
    /// Color of the impulse arrow.
    pub impulse_color: Color,
}

impl Default for ImpactGizmos {
    fn default() -> Self {
        Self {
            lifetime: 1.0,
            point_radius: 0.05,
            normal_length: 0.25,
            impulse_scale: 1.0,
            corrections: false,
            point_color: GOLD.into(),
            normal_color: LIME.into(),
            impulse_color: ORANGE_RED.into(),
        }
    }
}

/// An impact being drawn: when it was read, where, and its normal and impulse.
#[derive(Clone, Copy, Debug)]
struct Shown {
    read_at: f64,
    point: Vec3,
    normal: Vec3,
    impulse: Vec3,
}

/// Reads the frame's impacts and draws those of the last `lifetime` seconds.
fn draw_impacts(
    mut gizmos: Gizmos<ImpactGizmos>,
    mut messages: MessageReader<ImpactMessage>,
    time: Res<Time>,
    mut shown: Local<Vec<Shown>>,
) {
    let style = gizmos.config_ext.clone();
    let now = time.elapsed_secs_f64();
    shown.extend(
        messages
            .read()
            .filter(|m| style.corrections || m.event.kind == EventKind::Impact)
            .map(|m| Shown {
                read_at: now,
                point: m.event.point,
                normal: m.event.normal,
                impulse: m.event.impulse,
            }),
    );
    shown.retain(|s| now - s.read_at <= f64::from(style.lifetime));
    for s in shown.iter() {
        let facing = Quat::from_rotation_arc(Vec3::Z, s.normal.normalize_or(Vec3::Z));
        gizmos.circle(
            Isometry3d::new(s.point, facing),
            style.point_radius,
            style.point_color,
        );
        gizmos.line(
            s.point,
            s.point + s.normal * style.normal_length,
            style.normal_color,
        );
        let tip = s.point + s.impulse * style.impulse_scale;
        if tip != s.point {
            gizmos.arrow(s.point, tip, style.impulse_color);
        }
    }
}

//! The hook flags a collider is left with: whatever the user sets between steps is theirs,
//! and is what the plugin hands back (on `detach`, an unmarked ground, an excluded body, or
//! the flags moving from the grounds to the bodies), even flags that hold the plugin's own
//! bits; a ground whose flags the user sets again (to what they were before the plugin's)
//! is flagged again at once; a collider that moves from one flagged body to another, or from
//! a flagged body to the grounds, keeps the plugin's flags while one of them needs them, and
//! no longer once none does.

// Precision-generic: `Real` is f32 or f64 (feature `f64`).
#![allow(clippy::useless_conversion, clippy::unnecessary_cast)]

mod plugin_support;

use plugin_support::*;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{GroundMaterial, ImpactConfig, ImpactPlugin};
use std::sync::Mutex;

const PLUGINS: ActiveHooks =
    ActiveHooks::FILTER_CONTACT_PAIRS.union(ActiveHooks::MODIFY_SOLVER_CONTACTS);
const NONE: ActiveHooks = ActiveHooks::empty();
const MODIFY: ActiveHooks = ActiveHooks::MODIFY_SOLVER_CONTACTS;

fn flags(w: &PhysicsWorld, c: ColliderHandle) -> ActiveHooks {
    w.colliders[c].active_hooks()
}

/// A half-space ground with the user's `hooks`.
fn ground(w: &mut PhysicsWorld, hooks: ActiveHooks) -> ColliderHandle {
    let floor = ColliderBuilder::halfspace(up())
        .restitution(0.7)
        .active_hooks(hooks);
    w.insert(RigidBodyBuilder::fixed(), floor).1
}

/// A ball of radius 0.1 at `x`, resting on the ground (1 mm above it) unless `y` says.
fn ball(
    w: &mut PhysicsWorld,
    x: f64,
    y: f64,
    hooks: ActiveHooks,
) -> (RigidBodyHandle, ColliderHandle) {
    w.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(real(x), real(y), 0.0)),
        ColliderBuilder::ball(0.1)
            .restitution(0.7)
            .active_hooks(hooks),
    )
}

/// The plugin with the default configuration and the ground `g`.
fn plugin_with_ground(w: &PhysicsWorld, g: ColliderHandle) -> ImpactPlugin {
    let mut p = ImpactPlugin::new(ImpactConfig::default()).unwrap();
    p.add_ground(&w.bodies, &w.colliders, g).unwrap();
    p
}

/// Records which collider pairs reach the user's hook, and through which call.
#[derive(Default)]
struct Recording(Mutex<Vec<(ColliderHandle, ColliderHandle, bool)>>);

impl PhysicsHooks for Recording {
    fn filter_contact_pair(&self, c: &PairFilterContext) -> Option<SolverFlags> {
        self.0
            .lock()
            .unwrap()
            .push((c.collider1, c.collider2, true));
        Some(SolverFlags::default())
    }
    fn modify_solver_contacts(&self, c: &mut ContactModificationContext) {
        self.0
            .lock()
            .unwrap()
            .push((c.collider1, c.collider2, false));
    }
}

impl Recording {
    /// (filter calls, modify calls) since the last count.
    fn count(&self) -> (usize, usize) {
        let mut calls = self.0.lock().unwrap();
        let filter = calls.iter().filter(|c| c.2).count();
        let counts = (filter, calls.len() - filter);
        calls.clear();
        counts
    }
}

/// Each way the plugin gives flags back, after the user set new ones on the collider since
/// the last step: the new ones stay.
#[test]
fn flags_the_user_sets_between_steps_are_the_ones_handed_back() {
    // (what the plugin is told between the steps, which collider the user changes)
    #[derive(Clone, Copy, Debug)]
    enum GiveBack {
        Detach,
        UnmarkGround,
        ExcludeFlaggedBall,
        FlagsMoveToTheBodies,
    }
    for way in [
        GiveBack::Detach,
        GiveBack::UnmarkGround,
        GiveBack::ExcludeFlaggedBall,
        GiveBack::FlagsMoveToTheBodies,
    ] {
        let mut w = PhysicsWorld::default();
        let g = ground(&mut w, NONE);
        let (far, _) = ball(&mut w, 3.0, 0.101, NONE);
        let (b, c) = ball(&mut w, 0.0, 0.101, NONE);
        let mut p = plugin_with_ground(&w, g);
        // The flags on the ball: one dynamic body unmanaged.
        let on_ball = matches!(way, GiveBack::ExcludeFlaggedBall);
        if on_ball {
            p.exclude_body(far);
        }
        p.step(&mut w);
        let changed = if on_ball { c } else { g };
        assert_eq!(flags(&w, changed), PLUGINS, "{way:?}: flagged");
        w.colliders[changed].set_active_hooks(MODIFY);
        match way {
            GiveBack::Detach => {
                p.detach(&mut w.colliders);
            }
            GiveBack::UnmarkGround => {
                p.remove_ground(g);
                p.step(&mut w);
            }
            GiveBack::ExcludeFlaggedBall => {
                p.exclude_body(b);
                p.step(&mut w);
            }
            GiveBack::FlagsMoveToTheBodies => {
                p.exclude_body(far);
                p.step(&mut w);
            }
        }
        assert_eq!(flags(&w, changed), MODIFY, "{way:?}: the user's last flags");
    }
}

/// The user's new flags may hold the plugin's two bits and more: they are the user's, so
/// the wrapped hook is called for the ground's pairs, and `detach` leaves them.
#[test]
fn user_flags_that_hold_the_plugins_bits_are_the_users() {
    let mut w = PhysicsWorld::default();
    let g = ground(&mut w, NONE);
    ball(&mut w, 0.0, 0.101, NONE);
    let mut p = ImpactPlugin::with_hooks(ImpactConfig::default(), Recording::default()).unwrap();
    p.add_ground(&w.bodies, &w.colliders, g).unwrap();
    p.step(&mut w);
    assert_eq!(p.user_hooks().count(), (0, 0), "no flags of the user's yet");
    let mine = PLUGINS | ActiveHooks::FILTER_INTERSECTION_PAIR;
    w.colliders[g].set_active_hooks(mine);
    for _ in 0..10 {
        p.step(&mut w);
    }
    let (filter, modify) = p.user_hooks().count();
    assert!(
        filter > 0 && modify > 0,
        "the user's hook asked: {filter} / {modify}"
    );
    p.detach(&mut w.colliders);
    assert_eq!(flags(&w, g), mine);
}

/// A box sliding at 2 m/s over a ground whose material has no friction: it keeps sliding
/// whether or not the user sets the ground's flags again, to what they were before the
/// plugin's, after the first step. Returns its speed after half a second.
fn slide(set_again: bool) -> f64 {
    let mut w = PhysicsWorld::default();
    let slab = ColliderBuilder::cuboid(50.0, 0.1, 50.0)
        .translation(Vector::new(0.0, -0.1, 0.0))
        .friction(1.0);
    let (_, g) = w.insert(RigidBodyBuilder::fixed(), slab);
    let (b, _) = w.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, 0.1, 0.0))
            .linvel(Vector::new(2.0, 0.0, 0.0)),
        ColliderBuilder::cuboid(0.1, 0.1, 0.1).friction(1.0),
    );
    let mut p = ImpactPlugin::new(ImpactConfig::default()).unwrap();
    let frictionless = GroundMaterial::new(0.0, 0.0);
    p.add_ground_with_material(&w.bodies, &w.colliders, g, frictionless)
        .unwrap();
    p.step(&mut w);
    if set_again {
        w.colliders[g].set_active_hooks(NONE);
    }
    for _ in 0..30 {
        p.step(&mut w);
        assert_eq!(flags(&w, g), PLUGINS, "the ground flagged again at once");
    }
    wide(w.bodies[b].linvel().x)
}

/// A ground whose flags the user sets to what they were before the plugin's is flagged
/// again at the next step: right after the plugin first flags it, and after the grounds
/// lost their flags in an idle spell (a ball in flight far above) and got them back.
#[test]
fn a_ground_whose_flags_the_user_sets_again_is_flagged_again() {
    let (kept, set_again) = (slide(false), slide(true));
    assert!(kept > 1.99, "no friction: {kept}");
    assert_eq!(kept, set_again, "the ground's friction override holds");

    let mut w = PhysicsWorld::default();
    let g = ground(&mut w, NONE);
    w.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, 10.0, 0.0))
            .linvel(Vector::new(0.0, 5.0, 0.0)),
        ColliderBuilder::ball(0.1).restitution(0.7),
    );
    let mut p = plugin_with_ground(&w, g);
    let mut steps = 0;
    while flags(&w, g) != PLUGINS {
        p.step(&mut w);
        steps += 1;
        assert!(steps < 300, "the ball nears the ground");
    }
    w.colliders[g].set_active_hooks(NONE);
    for _ in 0..20 {
        p.step(&mut w);
        assert_eq!(flags(&w, g), PLUGINS);
    }
}

/// A collider moved from one flagged ball to another (the flags on the bodies: one dynamic
/// body unmanaged) keeps the flags while its new body needs them, loses them once it does
/// not, and the user's hook, asked by no collider, is never called.
#[test]
fn a_collider_moved_between_flagged_bodies_keeps_the_users_flags() {
    let mut w = PhysicsWorld::default();
    let g = ground(&mut w, NONE);
    let (unmanaged, _) = ball(&mut w, 5.0, 0.101, NONE);
    let (_, c) = ball(&mut w, 0.0, 0.101, NONE);
    let (b, _) = ball(&mut w, 2.0, 0.101, NONE);
    let mut p = ImpactPlugin::with_hooks(ImpactConfig::default(), Recording::default()).unwrap();
    p.add_ground(&w.bodies, &w.colliders, g).unwrap();
    p.exclude_body(unmanaged);
    p.step(&mut w);
    assert_eq!(flags(&w, c), PLUGINS);
    w.colliders.set_parent(c, Some(b), &mut w.bodies);
    for _ in 0..3 {
        p.step(&mut w);
        assert_eq!(flags(&w, c), PLUGINS, "its new body is near the ground");
    }
    p.exclude_body(b);
    for _ in 0..5 {
        w.bodies[b].wake_up(true);
        p.step(&mut w);
        assert_eq!(flags(&w, c), NONE, "no managed body holds it");
    }
    assert_eq!(
        p.user_hooks().count(),
        (0, 0),
        "no collider asks for the user's hook"
    );
    p.detach(&mut w.colliders);
    assert_eq!((flags(&w, c), flags(&w, g)), (NONE, NONE));
}

/// A flagged ball made fixed and marked as a ground, with the flags back on the grounds:
/// flagged as a ground from that step on, and given back on `detach`.
#[test]
fn a_flagged_ball_made_a_ground_stays_flagged() {
    let mut w = PhysicsWorld::default();
    let g = ground(&mut w, NONE);
    let (unmanaged, _) = ball(&mut w, 5.0, 0.101, NONE);
    let (a, c) = ball(&mut w, 0.0, 0.101, MODIFY);
    let mut p = plugin_with_ground(&w, g);
    p.exclude_body(unmanaged);
    p.step(&mut w);
    assert_eq!(flags(&w, c), PLUGINS);
    w.bodies[a].set_body_type(RigidBodyType::Fixed, true);
    p.add_ground(&w.bodies, &w.colliders, c).unwrap();
    p.include_body(unmanaged);
    for _ in 0..3 {
        p.step(&mut w);
        assert_eq!((flags(&w, c), flags(&w, g)), (PLUGINS, PLUGINS));
    }
    p.detach(&mut w.colliders);
    assert_eq!((flags(&w, c), flags(&w, g)), (MODIFY, NONE));
}

/// `user_active_hooks` gives the user's own flags while the plugin's are on, so that a flag
/// added to them (read, add, write) is the user's: the wrapped filter is asked for the
/// ground's pairs; the same flag added to the collider's current flags (the plugin's
/// included) reads as no change and is not.
#[test]
fn a_flag_added_to_the_users_own_flags_is_theirs() {
    for through_getter in [true, false] {
        let mut w = PhysicsWorld::default();
        let g = ground(&mut w, NONE);
        ball(&mut w, 0.0, 0.101, NONE);
        let mut p =
            ImpactPlugin::with_hooks(ImpactConfig::default(), Recording::default()).unwrap();
        p.add_ground(&w.bodies, &w.colliders, g).unwrap();
        p.step(&mut w);
        assert_eq!(p.user_active_hooks(&w.colliders, g), NONE);
        let current = if through_getter {
            p.user_active_hooks(&w.colliders, g)
        } else {
            flags(&w, g)
        };
        w.colliders[g].set_active_hooks(current | ActiveHooks::FILTER_CONTACT_PAIRS);
        for _ in 0..5 {
            p.step(&mut w);
        }
        let (filter, _) = p.user_hooks().count();
        let theirs = p.user_active_hooks(&w.colliders, g);
        if through_getter {
            assert_eq!(theirs, ActiveHooks::FILTER_CONTACT_PAIRS);
            assert!(filter > 0, "the user's filter asked");
        } else {
            assert_eq!((theirs, filter), (NONE, 0), "the plugin's value: no change");
        }
    }
}

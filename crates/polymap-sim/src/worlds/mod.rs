//! The built-in worlds, one file each. [`crate::World`] exposes them as named constructors.

pub(crate) mod build;
pub(crate) mod clutter;
pub(crate) mod corridor;
pub(crate) mod curve;
pub(crate) mod hall360;
pub(crate) mod hallway45;
pub(crate) mod hex60;
pub(crate) mod moved;
pub(crate) mod office;
pub(crate) mod ring;

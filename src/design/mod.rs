//! Designing the sequence library for the person: how long each entry
//! takes this user to breathe and how often a misread breath lands in
//! another entry ([`analysis`]), and the library that minimises both for
//! their usage ([`search`]).
//!
//! One sample's path: a [`Breathing`](breathing::Breathing) says how the
//! person breathes; [`reading`] lists what the detector may read instead
//! of a meant sequence and what the matcher then does; [`analysis`] sums
//! it per entry, weighted by the [`usage`] mix; [`search`] places the
//! entries on sequences to minimise that sum.

pub mod analysis;
pub mod breathing;
pub mod library_file;
pub mod plot;
pub mod reading;
pub mod search;
pub mod usage;
